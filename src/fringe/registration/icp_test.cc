#include "fringe/registration/icp.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fringe/sim/demo_part.h"
#include "fringe/testing/registration_views.h"
#include "fringe/util/error.h"

namespace fringe::registration {
namespace {

constexpr double kRotTolDeg = 1e-3;  // noise-free synthetic surface: ICP must land on the truth
constexpr double kTransTolMm = 1e-3;

// A wavy height field z = 5 sin(x / 13) cos(y / 17) + 0.002 x^2 sampled on a 0.5 mm grid, normals
// analytic (toward +z, where the sensor would be after `sensor_from_world`).
PointCloud WavySurface(const Rigid3d& sensor_from_world, double x0, double x1) {
  PointCloud c;
  for (double x = x0; x <= x1; x += 0.5) {
    for (double y = -40; y <= 40; y += 0.5) {
      const double z = 5 * std::sin(x / 13) * std::cos(y / 17) + 0.002 * x * x;
      const double dzdx = 5 / 13.0 * std::cos(x / 13) * std::cos(y / 17) + 0.004 * x;
      const double dzdy = -5 / 17.0 * std::sin(x / 13) * std::sin(y / 17);
      c.points.push_back(sensor_from_world * Eigen::Vector3d(x, y, z));
      c.normals.push_back(
          sensor_from_world.RotateDirection(Eigen::Vector3d(-dzdx, -dzdy, 1).normalized()));
    }
  }
  return c;
}

TEST(AlignPointToPlane, RecoversAKnownMotion) {
  const PointCloud target = WavySurface(Rigid3d(), -40, 20);
  const Rigid3d source_from_world =
      Rigid3d::FromAxisAngle(Eigen::Vector3d(0.2, 1, 0.3).normalized(), 0.4, {10, -20, 300});
  const PointCloud source = WavySurface(source_from_world, -20, 40);
  const Rigid3d truth = source_from_world.Inverse();  // target(world)_from_source
  const Rigid3d start = Rigid3d::FromAxisAngle(Eigen::Vector3d(1, -1, 0.5).normalized(),
                                               2 * M_PI / 180, {1.5, -1, 2}) *
                        truth;
  IcpOptions o;
  o.initial_threshold_mm = 8;
  const IcpResult r = AlignPointToPlane(source, target, start, o);
  ASSERT_TRUE(r.summary.ok()) << r.summary.BriefReport();
  const RigidDifference d = Difference(r.world_from_sensor[1], truth);
  EXPECT_LT(d.angle_rad * 180 / M_PI, kRotTolDeg) << r.summary.BriefReport();
  EXPECT_LT(d.translation_mm, kTransTolMm);
  // The threshold shrank from level to level and the residual fell.
  const auto& l = r.summary.levels;
  EXPECT_LT(l.back().threshold_end_mm, o.initial_threshold_mm / 4);
  EXPECT_LT(l.back().rms_end_mm, l.front().rms_start_mm / 10);
  EXPECT_NEAR(r.overlap[1][0], 2.0 / 3 * o.trim_fraction, 0.05);  // two thirds shared, trimmed
}

// Six quarter-resolution views of the demo part (320x256 cameras, ~0.8 mm per pixel on the part,
// read noise 1.5 DN, clouds reconstructed from the fringe images), every view but the first
// moved by 2 deg about its cloud centroid and 2 mm, all refined together. The part sits on a
// 260 x 200 mm plate: most points constrain only the plate's normal direction, the sliding
// directions rest on the part's walls, bores and crown. On this rig the objective is nearly
// flat along the plate (RMS residual changes by < 0.5 % over the last 0.5 mm of slide), so the
// translation tolerance is much looser than the rotation one; bench_registration measures the
// full-resolution figures.
constexpr double kDemoRotTolDeg = 0.015;
constexpr double kDemoCentroidTolMm = 0.8;
constexpr double kPerturbRotDeg = 2.0;
constexpr double kPerturbTransMm = 2.0;

TEST(RefineMultiView, ConvergesFromPerturbedPosesOnSimulatedDemoViewsAndTheThresholdShrinks) {
  const StereoRig rig = testing::SmallRig();
  sim::DemoPartOptions part;
  part.grid_mm = 0.5;  // the quarter rig does not resolve finer
  const sim::Scene scene = sim::MakeDemoPart(part);
  sim::OrbitOptions orbit;
  orbit.views = 6;
  const std::vector<Rigid3d> truth = sim::OrbitPoses(rig, {0, 0, 25}, orbit);
  std::vector<PointCloud> clouds;
  std::vector<ViewGrid> grids;
  std::vector<Eigen::Vector3d> centroids;  // sensor frame
  for (int v = 0; v < orbit.views; ++v) {
    const OrganizedPointCloud grid = testing::SimulateView(rig, scene, truth[v], v).rec.cloud;
    clouds.push_back(grid.Compact());
    grids.push_back(IndexViewGrid(grid));
    ASSERT_TRUE(grids.back().projection.fitted()) << "view " << v;
    ASSERT_GT(clouds.back().size(), 10000u) << "view " << v;
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (const auto& p : clouds.back().points) c += p;
    centroids.push_back(c / static_cast<double>(clouds.back().size()));
  }
  auto centroid_error = [&](const Rigid3d& est, int v) {
    return (est * centroids[v] - truth[v] * centroids[v]).norm();
  };
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<IcpView> views(orbit.views);
  double worst_start_mm = 0;
  for (int v = 0; v < orbit.views; ++v) {
    views[v].cloud = &clouds[v];
    views[v].world_from_sensor = truth[v];
    views[v].fixed = v == 0;  // the gauge: world = truth
    if (v == 0) continue;
    const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    const Eigen::Vector3d dir = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    const Eigen::Vector3d c = truth[v] * centroids[v];
    const Rigid3d turn = Rigid3d::FromAxisAngle(axis, kPerturbRotDeg * M_PI / 180);
    views[v].world_from_sensor =
        Rigid3d(turn.rotation(), c - turn.RotateDirection(c) + kPerturbTransMm * dir) * truth[v];
    worst_start_mm = std::max(worst_start_mm, centroid_error(views[v].world_from_sensor, v));
  }
  IcpOptions o;
  o.points_per_level = {1000, 4000, 12000};
  o.max_iterations_per_level = 12;
  o.initial_threshold_mm = 10;  // 2 deg at the part's ~100 mm lever plus 2 mm
  // The same views with their grids: projective association from level 1 on (level 0 starts
  // 2 deg / 2 mm off, several pixels, where only the k-d tree finds the nearest points).
  std::vector<IcpView> with_grids = views;
  for (int v = 0; v < orbit.views; ++v) with_grids[v].grid = &grids[v];
  for (const bool projective : {false, true}) {
    SCOPED_TRACE(projective ? "projective association" : "k-d tree association");
    const IcpResult r = RefineMultiView(projective ? with_grids : views, o);
    const int projective_pairs = r.summary.levels.back().projective_pairs;
    if (projective) {
      // Every view pair of the fine levels associated on the grid, none of level 0.
      EXPECT_EQ(r.summary.levels.front().projective_pairs, 0);
      EXPECT_EQ(projective_pairs, r.summary.levels.back().overlapping_pairs);
      EXPECT_GT(projective_pairs, 0);
    } else {
      EXPECT_EQ(projective_pairs, 0);
    }
    ASSERT_NE(r.summary.status, IcpStatus::kNoOverlap) << r.summary.BriefReport();
    double worst_mm = 0;
    for (int v = 1; v < orbit.views; ++v) {
      const RigidDifference d = Difference(r.world_from_sensor[v], truth[v]);
      EXPECT_LT(d.angle_rad * 180 / M_PI, kDemoRotTolDeg) << "view " << v << "\n"
                                                          << r.summary.BriefReport();
      EXPECT_LT(centroid_error(r.world_from_sensor[v], v), kDemoCentroidTolMm) << "view " << v;
      worst_mm = std::max(worst_mm, centroid_error(r.world_from_sensor[v], v));
    }
    EXPECT_LT(worst_mm, worst_start_mm / 3);
    // The threshold schedule: fixed within a level, shrinking from level to level, never below
    // the noise (the last one is 5 x the 80th percentile of ~0.05 mm residuals).
    const auto& l = r.summary.levels;
    ASSERT_EQ(l.size(), 3u);
    EXPECT_EQ(l[0].threshold_start_mm, o.initial_threshold_mm);
    EXPECT_LT(l[0].threshold_end_mm, l[0].threshold_start_mm);
    for (size_t k = 0; k < l.size(); ++k) {
      EXPECT_LE(l[k].threshold_end_mm, l[k].threshold_start_mm) << "level " << k;
      if (k > 0) {
        EXPECT_EQ(l[k].threshold_start_mm, l[k - 1].threshold_end_mm);
      }
    }
    EXPECT_LT(l.back().threshold_end_mm, o.initial_threshold_mm / 10);
    EXPECT_GT(l.back().threshold_end_mm, 0.1);
    EXPECT_LT(l.back().rms_end_mm, 0.1);
    EXPECT_LT(l.back().rms_end_mm, l.front().rms_start_mm / 10);
  }
}

// Projective association needs a grid that fits its cloud: one slot per point, inside the grid.
TEST(RefineMultiView, GridThatDoesNotFitItsCloudThrows) {
  const PointCloud a = WavySurface(Rigid3d(), -40, 20);
  OrganizedPointCloud grid(10, 10);
  grid.valid.assign(100, 1);
  ViewGrid g = IndexViewGrid(grid);  // 100 slots for a cloud of thousands of points
  IcpView t{&a, &g, Rigid3d(), true};
  IcpView s{&a, nullptr, Rigid3d(), false};
  EXPECT_THROW(RefineMultiView({t, s}), Error);
  g.slot_of_point.assign(a.size(), 100);  // one past the last slot
  EXPECT_THROW(RefineMultiView({t, s}), Error);
}

TEST(RefineMultiView, MissingNormalsThrow) {
  PointCloud c = WavySurface(Rigid3d(), -10, 10);
  c.normals.clear();
  EXPECT_THROW(AlignPointToPlane(c, c, Rigid3d()), Error);
}

}  // namespace
}  // namespace fringe::registration
