#include "fringe/registration/pose_graph.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fringe/util/error.h"

namespace fringe::registration {
namespace {

// Edges carry the true relative poses up to this much noise (the turn about the first view's
// sensor, up to 600 mm from the other views' centres: 0.1 mm there); placements compose at most
// three edges along the spanning tree. Errors measured at each view's centre.
constexpr double kEdgeNoiseDeg = 0.01;
constexpr double kEdgeNoiseMm = 0.01;
constexpr double kPlacedTolDeg = 0.05;
constexpr double kPlacedTolMm = 0.35;

// Rotation angle (deg) and the displacement of the view's centre (mm).
std::pair<double, double> PlacementError(const Rigid3d& est, const Rigid3d& truth,
                                         const Eigen::Vector3d& centre) {
  const RigidDifference d = Difference(est, truth);
  return {d.angle_rad * 180 / M_PI, (est * centre - truth * centre).norm()};
}

struct Graph {
  std::vector<Rigid3d> truth;  // world_from_view
  std::vector<Eigen::Vector3d> centres;
  std::vector<PoseGraphEdge> edges;
};

Rigid3d Noisy(const Rigid3d& t, std::mt19937* rng) {
  std::normal_distribution<double> n(0, 1);
  const Eigen::Vector3d axis(n(*rng), n(*rng), n(*rng));
  const Rigid3d d = Rigid3d::FromAxisAngle(
      axis.normalized(), kEdgeNoiseDeg * M_PI / 180,
      kEdgeNoiseMm * Eigen::Vector3d(n(*rng), n(*rng), n(*rng)).normalized());
  return d * t;
}

// Views on a circle around an object, every pair with an edge (a_from_b, slightly noisy).
Graph AllPairs(int views) {
  Graph g;
  std::mt19937 rng(3);
  for (int v = 0; v < views; ++v) {
    const double az = 2 * M_PI * v / views;
    g.truth.push_back(Rigid3d::FromAxisAngle(
        Eigen::Vector3d::UnitY(), az, Eigen::Vector3d(300 * std::sin(az), 0, -300 * std::cos(az))));
    g.centres.emplace_back(0, 0, 300);
  }
  for (int a = 0; a < views; ++a) {
    for (int b = a + 1; b < views; ++b) {
      g.edges.push_back(
          {a, b, Noisy(g.truth[a].Inverse() * g.truth[b], &rng), 100.0 + a + b, false});
    }
  }
  return g;
}

std::vector<std::optional<Rigid3d>> WorldOnly(const Graph& g) {
  std::vector<std::optional<Rigid3d>> known(g.truth.size());
  known[0] = g.truth[0];
  return known;
}

TEST(PoseGraphOptions, DefaultsPassCheck) { EXPECT_NO_THROW(PoseGraphOptions().Check()); }

TEST(SolvePoseGraph, ConsistentEdgesPlaceEveryView) {
  const Graph g = AllPairs(5);
  const PoseGraphResult r = SolvePoseGraph(WorldOnly(g), g.centres, g.edges);
  EXPECT_EQ(r.rejected, 0);
  for (int v = 0; v < 5; ++v) {
    ASSERT_TRUE(r.world_from_view[v].has_value()) << v << ": " << r.view_message[v];
    const auto [deg, mm] = PlacementError(*r.world_from_view[v], g.truth[v], g.centres[v]);
    EXPECT_LT(deg, kPlacedTolDeg) << v;
    EXPECT_LT(mm, kPlacedTolMm) << v;
  }
}

// One edge replaced by a pose slid 20 mm along the object (what a repetitive part's wrong
// candidate looks like), with the highest weight so that the spanning tree would take it.
TEST(SolvePoseGraph, RejectsAnInjectedWrongEdge) {
  Graph g = AllPairs(5);
  int wrong = -1;
  for (size_t e = 0; e < g.edges.size(); ++e) {
    if (g.edges[e].a == 1 && g.edges[e].b == 3) wrong = static_cast<int>(e);
  }
  ASSERT_GE(wrong, 0);
  g.edges[wrong].a_from_b =
      Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(20, 0, 0)) * g.edges[wrong].a_from_b;
  g.edges[wrong].weight = 1000;
  const PoseGraphResult r = SolvePoseGraph(WorldOnly(g), g.centres, g.edges);
  EXPECT_EQ(r.rejected, 1);
  EXPECT_FALSE(r.edge_kept[wrong]);
  EXPECT_NE(r.edge_message[wrong].find("cycle"), std::string::npos) << r.edge_message[wrong];
  for (size_t e = 0; e < g.edges.size(); ++e) {
    if (static_cast<int>(e) != wrong) {
      EXPECT_TRUE(r.edge_kept[e]) << e;
    }
  }
  for (int v = 0; v < 5; ++v) {
    ASSERT_TRUE(r.world_from_view[v].has_value()) << v;
    const auto [deg, mm] = PlacementError(*r.world_from_view[v], g.truth[v], g.centres[v]);
    EXPECT_LT(deg, kPlacedTolDeg) << v;
    EXPECT_LT(mm, kPlacedTolMm) << v;
  }
}

// View 2's two edges disagree with each other through the known pair (0, 1): the triangle
// cannot say which is wrong, so both go and view 2 stays unplaced, with the reason.
TEST(SolvePoseGraph, AnUndecidableTriangleLeavesTheViewUnplaced) {
  Graph g = AllPairs(3);
  std::vector<std::optional<Rigid3d>> known(3);
  known[0] = g.truth[0];
  known[1] = g.truth[1];
  for (PoseGraphEdge& e : g.edges) {
    if (e.a == 0 && e.b == 1) e.fixed = true;
    if (e.a == 0 && e.b == 2) {
      e.a_from_b = Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitZ(), 0.1) * e.a_from_b;
    }
  }
  const PoseGraphResult r = SolvePoseGraph(known, g.centres, g.edges);
  EXPECT_EQ(r.rejected, 2);
  EXPECT_FALSE(r.world_from_view[2].has_value());
  EXPECT_NE(r.view_message[2].find("rejected"), std::string::npos) << r.view_message[2];
  EXPECT_TRUE(r.world_from_view[1].has_value());
}

TEST(SolvePoseGraph, AViewWithoutEdgesIsReported) {
  Graph g = AllPairs(3);
  g.truth.push_back(g.truth[2]);
  g.centres.push_back(g.centres[2]);
  std::vector<std::optional<Rigid3d>> known(4);
  known[0] = g.truth[0];
  const PoseGraphResult r = SolvePoseGraph(known, g.centres, g.edges);
  EXPECT_FALSE(r.world_from_view[3].has_value());
  EXPECT_NE(r.view_message[3].find("no verified"), std::string::npos) << r.view_message[3];
  EXPECT_THROW(SolvePoseGraph(std::vector<std::optional<Rigid3d>>(4), g.centres, g.edges), Error);
  std::vector<PoseGraphEdge> bad = g.edges;
  bad[0].b = bad[0].a;
  EXPECT_THROW(SolvePoseGraph(known, g.centres, bad), Error);
}

}  // namespace
}  // namespace fringe::registration
