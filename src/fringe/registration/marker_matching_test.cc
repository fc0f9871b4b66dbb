#include "fringe/registration/marker_matching.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>

#include "fringe/geometry/align.h"
#include "fringe/util/error.h"

namespace fringe::registration {
namespace {

constexpr double kNoiseMm = 0.02;  // marker centre noise of a full-resolution view
constexpr double kPoseRotTolDeg = 0.02;
constexpr double kPoseTransTolMm = 0.05;  // at the markers' centroid

// A random, asymmetric marker layout on a bumpy 200 x 150 mm part (normals up-ish).
std::vector<MarkerPoint> RandomLayout(int n, std::mt19937* rng) {
  std::uniform_real_distribution<double> ux(-100, 100), uy(-75, 75), uz(0, 40), un(-0.3, 0.3);
  std::vector<MarkerPoint> out;
  while (static_cast<int>(out.size()) < n) {
    MarkerPoint p;
    p.centre = {ux(*rng), uy(*rng), uz(*rng)};
    bool close = false;
    for (const auto& q : out) close |= (q.centre - p.centre).norm() < 8;
    if (close) continue;
    p.normal = Eigen::Vector3d(un(*rng), un(*rng), 1).normalized();
    p.sigma_mm = kNoiseMm;
    out.push_back(p);
  }
  return out;
}

Rigid3d SomePose() {
  return Rigid3d::FromAxisAngle(Eigen::Vector3d(0.3, -0.5, 0.8).normalized(), 1.1,
                                Eigen::Vector3d(40, -500, 120));
}

// view = sensor_from_world * (subset of map) + noise
std::vector<MarkerPoint> SeeFrom(const std::vector<MarkerPoint>& world, const std::vector<int>& ids,
                                 const Rigid3d& sensor_from_world, std::mt19937* rng) {
  std::normal_distribution<double> noise(0, kNoiseMm);
  std::vector<MarkerPoint> out;
  for (int id : ids) {
    MarkerPoint p = world[id];
    p.centre =
        sensor_from_world * p.centre + Eigen::Vector3d(noise(*rng), noise(*rng), noise(*rng));
    p.normal = sensor_from_world.RotateDirection(p.normal);
    out.push_back(p);
  }
  return out;
}

TEST(MarkerMatchOptions, DefaultsPassCheck) { EXPECT_NO_THROW(MarkerMatchOptions().Check()); }

TEST(MatchMarkers, MissingExtraAndOutlierMarkers) {
  std::mt19937 rng(7);
  const std::vector<MarkerPoint> map = RandomLayout(30, &rng);
  // The view sees 14 of the map's markers (16 missing) ...
  std::vector<int> ids;
  for (int k = 0; k < 30; k += 2) ids.push_back(k);
  ids.pop_back();
  const Rigid3d world_from_sensor = SomePose();
  std::vector<MarkerPoint> view = SeeFrom(map, ids, world_from_sensor.Inverse(), &rng);
  const size_t shared = view.size();
  // ... plus 4 markers the map has not seen yet ...
  const std::vector<MarkerPoint> fresh = RandomLayout(4, &rng);
  for (MarkerPoint p : fresh) {
    p.centre = world_from_sensor.Inverse() * (p.centre + Eigen::Vector3d(0, 0, 60));
    view.push_back(p);
  }
  // ... and 2 outliers: shared markers measured 3 mm off.
  view[1].centre += Eigen::Vector3d(3, 0, 0);
  view[5].centre += Eigen::Vector3d(0, -2, 2);

  const MarkerMatchResult r = MatchMarkers(view, map);
  ASSERT_TRUE(r.ok()) << r.BriefReport();
  const RigidDifference d = Difference(r.map_from_view, world_from_sensor);
  EXPECT_LT(d.angle_rad * 180 / M_PI, kPoseRotTolDeg);
  // Translation error where the markers are (the pose's own origin is 500 mm away, where any
  // rotation error is magnified).
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (size_t k = 0; k < shared; ++k) centroid += view[k].centre / static_cast<double>(shared);
  EXPECT_LT((r.map_from_view * centroid - world_from_sensor * centroid).norm(), kPoseTransTolMm);
  // Every correspondence correct; all shared markers but the two outliers found.
  for (const auto& [v, m] : r.pairs) {
    ASSERT_LT(static_cast<size_t>(v), shared) << "an unseen marker was matched";
    EXPECT_EQ(ids[v], m);
    EXPECT_NE(v, 1);
    EXPECT_NE(v, 5);
  }
  EXPECT_EQ(r.pairs.size(), shared - 2);
}

TEST(MatchMarkers, ViewsInAnyFrameAndOrder) {
  std::mt19937 rng(11);
  const std::vector<MarkerPoint> map = RandomLayout(12, &rng);
  std::vector<int> ids = {11, 3, 7, 0, 5, 9, 1};  // shuffled order
  const Rigid3d world_from_sensor =
      Rigid3d::FromAxisAngle(Eigen::Vector3d(1, 0, 0), M_PI * 0.9, Eigen::Vector3d(5, 5, 700));
  const MarkerMatchResult r =
      MatchMarkers(SeeFrom(map, ids, world_from_sensor.Inverse(), &rng), map);
  ASSERT_TRUE(r.ok()) << r.BriefReport();
  ASSERT_EQ(r.pairs.size(), ids.size());
  for (const auto& [v, m] : r.pairs) EXPECT_EQ(ids[v], m);
}

// Triangulated centres are far less certain along the viewing ray (the sensor's z) than
// across it. With the full covariances the fit weighs each direction by its own uncertainty;
// with only the scalar sigma it cannot. Over 20 random layouts, the pose error (rotation, and
// displacement at the markers' centroid) must come out smaller with the covariances.
TEST(MatchMarkers, FullCovariancesBeatScalarSigmasForRayElongatedNoise) {
  constexpr double kAlongRayMm = 0.05, kAcrossRayMm = 0.005;
  std::mt19937 rng(23);
  std::normal_distribution<double> across(0, kAcrossRayMm), along(0, kAlongRayMm);
  double ss_rot_full = 0, ss_rot_scalar = 0, ss_tr_full = 0, ss_tr_scalar = 0;
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<MarkerPoint> map = RandomLayout(15, &rng);
    for (MarkerPoint& p : map) p.sigma_mm = 1e-3;  // a map known far better than the view
    const Rigid3d world_from_sensor = SomePose();
    const Rigid3d sensor_from_world = world_from_sensor.Inverse();
    std::vector<MarkerPoint> full, scalar;
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (const MarkerPoint& m : map) {
      MarkerPoint p = m;
      const Eigen::Vector3d c = sensor_from_world * m.centre;
      const Eigen::Vector3d ray = c.normalized();
      const Eigen::Vector3d u = ray.unitOrthogonal(), w = ray.cross(u);
      p.centre = c + along(rng) * ray + across(rng) * u + across(rng) * w;
      p.normal = sensor_from_world.RotateDirection(m.normal);
      p.covariance = kAlongRayMm * kAlongRayMm * ray * ray.transpose() +
                     kAcrossRayMm * kAcrossRayMm * (u * u.transpose() + w * w.transpose());
      p.sigma_mm = std::sqrt(p.covariance.trace());
      full.push_back(p);
      p.covariance.setZero();
      scalar.push_back(p);
      centroid += c / static_cast<double>(map.size());
    }
    const MarkerMatchResult rf = MatchMarkers(full, map);
    const MarkerMatchResult rs = MatchMarkers(scalar, map);
    ASSERT_TRUE(rf.ok()) << rf.BriefReport();
    ASSERT_TRUE(rs.ok()) << rs.BriefReport();
    ss_rot_full += std::pow(Difference(rf.map_from_view, world_from_sensor).angle_rad, 2);
    ss_rot_scalar += std::pow(Difference(rs.map_from_view, world_from_sensor).angle_rad, 2);
    ss_tr_full += (rf.map_from_view * centroid - world_from_sensor * centroid).squaredNorm();
    ss_tr_scalar += (rs.map_from_view * centroid - world_from_sensor * centroid).squaredNorm();
  }
  std::cout << "RMS rotation error " << std::sqrt(ss_rot_full / 20) * 180 / M_PI << " vs "
            << std::sqrt(ss_rot_scalar / 20) * 180 / M_PI << " deg, centroid "
            << std::sqrt(ss_tr_full / 20) << " vs " << std::sqrt(ss_tr_scalar / 20) << " mm\n";
  EXPECT_LT(ss_rot_full, 0.5 * ss_rot_scalar);
  EXPECT_LT(ss_tr_full, ss_tr_scalar);
}

// Eight markers at the corners of two concentric squares: every quarter turn about the centre
// maps the layout onto itself, normals included. No match can be right: refuse.
TEST(MatchMarkers, RotationallySymmetricLayoutIsRefused) {
  std::vector<MarkerPoint> map;
  for (double r : {30.0, 55.0}) {
    for (int k = 0; k < 4; ++k) {
      MarkerPoint p;
      const double a = k * M_PI / 2 + (r > 40 ? 0.3 : 0);
      p.centre = {r * std::cos(a), r * std::sin(a), 0};
      p.normal = Eigen::Vector3d::UnitZ();
      p.sigma_mm = kNoiseMm;
      map.push_back(p);
    }
  }
  std::mt19937 rng(3);
  const Rigid3d world_from_sensor = SomePose();
  const MarkerMatchResult r =
      MatchMarkers(SeeFrom(map, {0, 1, 2, 3, 4, 5, 6, 7}, world_from_sensor.Inverse(), &rng), map);
  EXPECT_EQ(r.status, MarkerMatchStatus::kAmbiguous) << r.BriefReport();
  EXPECT_TRUE(r.pairs.empty());
}

// A planar layout symmetric under a mirror: the mirror is no rigid motion, but the flip about
// the mirror line (a rigid half turn) maps the centres onto themselves and turns the normals
// over. With normals the match is unique and correct; without them it must be refused.
TEST(MatchMarkers, MirrorSymmetricLayoutDisambiguatedByNormals) {
  std::vector<MarkerPoint> map;
  for (const auto& xy : std::vector<Eigen::Vector2d>{{20, 10}, {45, -30}, {60, 35}, {15, -50}}) {
    for (double sx : {-1.0, 1.0}) {
      MarkerPoint p;
      p.centre = {sx * xy.x(), xy.y(), 0};
      p.normal = Eigen::Vector3d::UnitZ();
      p.sigma_mm = kNoiseMm;
      map.push_back(p);
    }
  }
  std::mt19937 rng(5);
  const Rigid3d world_from_sensor = SomePose();
  const std::vector<int> ids = {0, 1, 2, 3, 4, 5, 6, 7};
  std::vector<MarkerPoint> view = SeeFrom(map, ids, world_from_sensor.Inverse(), &rng);
  const MarkerMatchResult r = MatchMarkers(view, map);
  ASSERT_TRUE(r.ok()) << r.BriefReport();
  for (const auto& [v, m] : r.pairs) EXPECT_EQ(ids[v], m);
  EXPECT_LT(Difference(r.map_from_view, world_from_sensor).angle_rad * 180 / M_PI, kPoseRotTolDeg);

  for (auto* list : {&view}) {
    for (MarkerPoint& p : *list) p.normal.setZero();
  }
  std::vector<MarkerPoint> map_without_normals = map;
  for (MarkerPoint& p : map_without_normals) p.normal.setZero();
  const MarkerMatchResult blind = MatchMarkers(view, map_without_normals);
  EXPECT_EQ(blind.status, MarkerMatchStatus::kAmbiguous) << blind.BriefReport();
}

// A view whose marker layout is the MIRROR image of the map's (x -> -x; markers on a bumpy
// part, so the layout is not planar): every pairwise distance agrees, but no rigid motion maps
// one onto the other (only three-marker subsets, which are always congruent). Never a match.
TEST(MatchMarkers, MirrorImageOfTheMapIsNotMatched) {
  for (const unsigned seed : {11u, 12u, 13u, 14u, 15u, 16u, 17u, 18u}) {
    std::mt19937 rng(seed);
    const std::vector<MarkerPoint> map = RandomLayout(12, &rng);
    std::vector<MarkerPoint> mirrored = map;
    for (MarkerPoint& p : mirrored) {
      p.centre.x() = -p.centre.x();
      p.normal.x() = -p.normal.x();
    }
    std::vector<int> ids(map.size());
    for (size_t k = 0; k < ids.size(); ++k) ids[k] = static_cast<int>(k);
    const MarkerMatchResult r =
        MatchMarkers(SeeFrom(mirrored, ids, SomePose().Inverse(), &rng), map);
    EXPECT_FALSE(r.ok()) << "seed " << seed << ": " << r.BriefReport();
    EXPECT_TRUE(r.pairs.empty()) << "seed " << seed;
  }
}

TEST(MatchMarkers, TooFewAndUnrelatedMarkers) {
  std::mt19937 rng(9);
  const std::vector<MarkerPoint> map = RandomLayout(10, &rng);
  const MarkerMatchResult few = MatchMarkers(SeeFrom(map, {1, 2}, SomePose().Inverse(), &rng), map);
  EXPECT_EQ(few.status, MarkerMatchStatus::kTooFewMarkers);
  // A different random layout shares no distances with the map.
  std::mt19937 other(1234);
  const MarkerMatchResult unrelated = MatchMarkers(RandomLayout(8, &other), map);
  EXPECT_FALSE(unrelated.ok()) << unrelated.BriefReport();
}

TEST(MatchMarkers, NonFiniteInputThrows) {
  std::vector<MarkerPoint> v(3);
  v[1].centre.x() = std::nan("");
  EXPECT_THROW(MatchMarkers(v, v), Error);
}

}  // namespace
}  // namespace fringe::registration
