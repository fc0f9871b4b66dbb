#include "fringe/fusion/fuse.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <array>
#include <cmath>
#include <limits>

#include "fringe/geometry/mesh_index.h"
#include "fringe/sim/poses.h"
#include "fringe/sim/renderer.h"
#include "fringe/sim/scene.h"
#include "fringe/testing/fusion_views.h"
#include "fringe/util/error.h"

namespace fringe::fusion {
namespace {

using testing::TruthView;

// 320 x 256 cameras: about 0.8 mm point spacing at the working distance.
StereoRig TestRig() { return sim::ScaledRig(StereoRig::Reference(), 0.25); }

Rigid3d Looking(const StereoRig& rig, const Eigen::Vector3d& target, double tilt_deg) {
  const double a = tilt_deg * M_PI / 180;
  return sim::SensorPoseLookingAt(rig, target, Eigen::Vector3d(std::sin(a), 0.1, std::cos(a)));
}

struct Stats {
  int n = 0;
  double rms = 0;     // about zero (the truth)
  double spread = 0;  // standard deviation about the mean
};
Stats Accumulate(const std::vector<double>& d) {
  Stats s;
  double sum = 0, sum_sq = 0;
  for (double x : d) sum += x, sum_sq += x * x, ++s.n;
  if (s.n == 0) return s;
  s.rms = std::sqrt(sum_sq / s.n);
  s.spread = std::sqrt(std::max(0.0, sum_sq / s.n - (sum / s.n) * (sum / s.n)));
  return s;
}

// Signed heights above the plane z = 0 of a view's overlap points (as registered).
std::vector<double> OverlapHeights(const FusionView& v, const std::vector<uint8_t>& overlap) {
  std::vector<double> z;
  for (size_t i = 0; i < v.cloud.valid.size(); ++i) {
    if (v.cloud.valid[i] && overlap[i])
      z.push_back((v.world_from_sensor * v.cloud.cloud.points[i]).z());
  }
  return z;
}

std::vector<double> FusedOverlapHeights(const FusionResult& r) {
  std::vector<double> z;
  for (size_t i = 0; i < r.fused.size(); ++i) {
    if (r.support[i] >= 2) z.push_back(r.fused.points[i].z());
  }
  return z;
}

TEST(Fusion, DefaultOptionsPassCheckAndBadOptionsThrow) {
  EXPECT_NO_THROW(FusionOptions().Check());
  FusionOptions o;
  o.max_normal_angle_deg = 95;
  EXPECT_THROW(o.Check(), Error);
  o = FusionOptions();
  o.registration_rms_mm = -1;
  EXPECT_THROW(FuseViews({}, o), Error);
}

TEST(Fusion, TwoNoisySlightlyMisregisteredPlaneViewsFuseIntoOneThinnerLayer) {
  constexpr double kSigmaMm = 0.05;
  constexpr double kMaxNoiseRatio = 0.8;      // fused RMS / single-view RMS in the overlap
  constexpr double kMaxThicknessRatio = 1.2;  // spread along the normal, fused / one view
  constexpr double kMaxCountRatio = 1.3;      // fused points / one view's points in the overlap
  const StereoRig rig = TestRig();
  const sim::Renderer renderer(sim::MakePlaneScene(), rig);
  const Rigid3d pose0 = Looking(rig, {-25, 0, 0}, 15), pose1 = Looking(rig, {25, 0, 0}, -15);
  // A registration error of 0.01 mm and 0.003 degrees on the second view.
  const Rigid3d error = Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitX(), 0.003 * M_PI / 180,
                                               Eigen::Vector3d(0, 0.01, 0.01));
  const std::vector<FusionView> views = {
      TruthView(renderer, "a", pose0, pose0, kSigmaMm, 1),
      TruthView(renderer, "b", pose1, error * pose1, kSigmaMm, 2)};
  FusionOptions options;
  options.registration_rms_mm = 0.01;
  const FusionResult r = FuseViews(views, options);
  SCOPED_TRACE(r.summary.BriefReport());
  ASSERT_EQ(r.summary.status, FusionStatus::kOk);
  ASSERT_GT(r.summary.overlap_points, 5000);
  EXPECT_EQ(r.summary.unassigned, 0);

  const Stats a = Accumulate(OverlapHeights(views[0], r.overlap[0]));
  const Stats b = Accumulate(OverlapHeights(views[1], r.overlap[1]));
  const Stats fused = Accumulate(FusedOverlapHeights(r));
  const double single_rms = std::sqrt((a.rms * a.rms + b.rms * b.rms) / 2);
  EXPECT_LT(fused.rms, kMaxNoiseRatio * single_rms) << "single " << single_rms;
  EXPECT_LT(fused.spread, kMaxThicknessRatio * std::min(a.spread, b.spread));
  EXPECT_LT(fused.n, kMaxCountRatio * std::max(a.n, b.n));
  EXPECT_GT(fused.n, std::min(a.n, b.n) / kMaxCountRatio);
  // Every input point is accounted for: in a cluster or passed through.
  EXPECT_EQ(
      r.summary.overlap_points + r.summary.passed_through + r.summary.absorbed + r.summary.trimmed,
      r.summary.input_points);
}

TEST(Fusion, DoubleLayerFromA03MmRegistrationErrorCollapses) {
  constexpr double kSigmaMm = 0.02;
  constexpr double kOffsetMm = 0.3;
  constexpr double kMaxThicknessRatio = 1.2;
  const StereoRig rig = TestRig();
  const sim::Renderer renderer(sim::MakePlaneScene(), rig);
  const Rigid3d pose0 = Looking(rig, {-25, 0, 0}, 15), pose1 = Looking(rig, {25, 0, 0}, -15);
  const Rigid3d error(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, kOffsetMm));
  const std::vector<FusionView> views = {
      TruthView(renderer, "a", pose0, pose0, kSigmaMm, 1),
      TruthView(renderer, "b", pose1, error * pose1, kSigmaMm, 2)};
  FusionOptions options;
  options.registration_rms_mm = 0.1;  // the registration reports its residual
  const FusionResult r = FuseViews(views, options);
  SCOPED_TRACE(r.summary.BriefReport());
  ASSERT_EQ(r.summary.status, FusionStatus::kOk);
  const std::vector<double> za = OverlapHeights(views[0], r.overlap[0]);
  std::vector<double> concat = za;
  for (double z : OverlapHeights(views[1], r.overlap[1])) concat.push_back(z);
  const Stats a = Accumulate(za), both = Accumulate(concat),
              fused = Accumulate(FusedOverlapHeights(r));
  ASSERT_GT(both.spread, 3 * a.spread);  // the concatenation is a double layer
  EXPECT_LT(fused.spread, kMaxThicknessRatio * a.spread);
  // One layer between the two: the weighted mean sits between them.
  EXPECT_GT(fused.rms, 0.2 * kOffsetMm * 0.5);
  EXPECT_LT(fused.rms, 0.8 * kOffsetMm);
}

TEST(Fusion, SharpEdgeStaysSharp) {
  constexpr double kSigmaMm = 0.02;
  constexpr double kEdgeBandMm = 2.0;
  // Fused points near the edge stay on the faces, within the noise of one view's points there
  // (where the views disagree across the edge, a cluster keeps its best view's measurement
  // rather than averaging). Averaging along blurred normals instead gave 5x (0.07 mm RMS).
  constexpr double kMaxEdgeRatio = 1.25;
  constexpr double kMaxEdgeP100Mm = 0.15;
  const StereoRig rig = TestRig();
  sim::Scene scene;
  sim::SceneObject box;
  box.name = "box";
  box.mesh = sim::MakeBoxMesh({-40, -40, -30}, {40, 40, 0});
  scene.AddObject(box);
  const sim::Renderer renderer(scene, rig);
  // Both views see the top face and the +x side face; the edge is the line x = 40, z = 0.
  const Rigid3d pose0 =
      sim::SensorPoseLookingAt(rig, {40, 0, 0}, Eigen::Vector3d(1, 0.2, 1.2).normalized());
  const Rigid3d pose1 =
      sim::SensorPoseLookingAt(rig, {40, 0, 0}, Eigen::Vector3d(1.2, -0.2, 1).normalized());
  const std::vector<FusionView> views = {TruthView(renderer, "a", pose0, pose0, kSigmaMm, 1),
                                         TruthView(renderer, "b", pose1, pose1, kSigmaMm, 2)};
  const FusionResult r = FuseViews(views);
  SCOPED_TRACE(r.summary.BriefReport());
  ASSERT_EQ(r.summary.status, FusionStatus::kOk);
  const MeshIndex truth(box.mesh);
  auto near_edge = [&](const Eigen::Vector3d& p) {
    return std::hypot(p.x() - 40, p.z()) < kEdgeBandMm && std::abs(p.y()) < 30;
  };
  std::vector<double> single, fused;
  for (size_t i = 0; i < views[0].cloud.valid.size(); ++i) {
    if (!views[0].cloud.valid[i] || !r.overlap[0][i]) continue;
    const Eigen::Vector3d p = views[0].world_from_sensor * views[0].cloud.cloud.points[i];
    if (near_edge(p)) single.push_back(truth.SignedDistance(p));
  }
  double max_abs = 0;
  for (size_t i = 0; i < r.fused.size(); ++i) {
    if (r.support[i] < 2 || !near_edge(r.fused.points[i])) continue;
    fused.push_back(truth.SignedDistance(r.fused.points[i]));
    max_abs = std::max(max_abs, std::abs(fused.back()));
  }
  ASSERT_GT(single.size(), 50u);
  ASSERT_GT(fused.size(), 50u);
  EXPECT_LT(Accumulate(fused).rms, kMaxEdgeRatio * Accumulate(single).rms);
  EXPECT_LT(max_abs, kMaxEdgeP100Mm);
}

TEST(Fusion, NonOverlappingPartsPassThroughUnchanged) {
  const StereoRig rig = TestRig();
  const sim::Renderer renderer(sim::MakePlaneScene(1000), rig);
  const Rigid3d pose0 = Looking(rig, {-200, 0, 0}, 10), pose1 = Looking(rig, {200, 0, 0}, -10);
  const std::vector<FusionView> views = {TruthView(renderer, "a", pose0, pose0, 0.02, 1),
                                         TruthView(renderer, "b", pose1, pose1, 0.02, 2)};
  FusionOptions options;
  options.smooth_radius_px = 0;  // exactly unchanged (the default smooths along the normal)
  const FusionResult r = FuseViews(views, options);
  SCOPED_TRACE(r.summary.BriefReport());
  ASSERT_EQ(r.summary.status, FusionStatus::kNoOverlap);
  ASSERT_TRUE(r.summary.has_output());
  ASSERT_EQ(r.fused.size(), views[0].cloud.NumValid() + views[1].cloud.NumValid());
  // Passed-through points come in view and grid order, exactly as registered.
  size_t k = 0;
  for (const FusionView& v : views) {
    for (size_t i = 0; i < v.cloud.valid.size(); ++i) {
      if (!v.cloud.valid[i]) continue;
      ASSERT_EQ(r.fused.points[k], v.world_from_sensor * v.cloud.cloud.points[i]);
      ASSERT_EQ(r.fused.intensity[k], v.cloud.cloud.intensity[i]);
      ++k;
    }
  }
}

// The default single-coverage smoothing: every passed-through point moves along its normal only
// (no lateral smearing), by less than a few noise sigmas, and its error against the truth
// drops; on a plane it averages up to 9 points' depths.
TEST(Fusion, SingleCoveragePointsAreSmoothedAlongTheirNormalOnly) {
  const StereoRig rig = TestRig();
  const sim::Renderer renderer(sim::MakePlaneScene(1000), rig);
  const Rigid3d pose0 = Looking(rig, {-200, 0, 0}, 10), pose1 = Looking(rig, {200, 0, 0}, -10);
  constexpr double kNoiseMm = 0.02;
  const std::vector<FusionView> views = {TruthView(renderer, "a", pose0, pose0, kNoiseMm, 1),
                                         TruthView(renderer, "b", pose1, pose1, kNoiseMm, 2)};
  const FusionOptions options;  // smooth_radius_px = 1
  ASSERT_EQ(options.smooth_radius_px, 1);
  const FusionResult r = FuseViews(views, options);
  SCOPED_TRACE(r.summary.BriefReport());
  ASSERT_EQ(r.summary.status, FusionStatus::kNoOverlap);
  ASSERT_EQ(r.fused.size(), views[0].cloud.NumValid() + views[1].cloud.NumValid());
  // The estimated noise along the normal is the simulated one (the rays are within ~10 degrees
  // of the normal).
  constexpr double kNoiseTolerance = 0.2;
  EXPECT_NEAR(r.summary.single_coverage_noise_mm, kNoiseMm, kNoiseTolerance * kNoiseMm);
  const MeshIndex truth(sim::MakePlaneScene(1000).CombinedMesh());
  std::vector<double> before, after;
  size_t k = 0;
  for (const FusionView& v : views) {
    for (size_t i = 0; i < v.cloud.valid.size(); ++i) {
      if (!v.cloud.valid[i]) continue;
      const Eigen::Vector3d p = v.world_from_sensor * v.cloud.cloud.points[i];
      const Eigen::Vector3d n = v.world_from_sensor.RotateDirection(v.cloud.cloud.normals[i]);
      const Eigen::Vector3d moved = r.fused.points[k] - p;
      // Along the normal only, and by less than 4 noise sigmas.
      ASSERT_LT((moved - moved.dot(n) * n).norm(), 1e-9);
      ASSERT_LT(moved.norm(), 4 * kNoiseMm);
      before.push_back(truth.SignedDistance(p));
      after.push_back(truth.SignedDistance(r.fused.points[k]));
      ++k;
    }
  }
  // 9 points, the farther offsets down-weighted by the range kernel: measured 0.52 of the
  // noise (equal weights would give 1/3); unsmoothed would be 1.
  constexpr double kMaxNoiseRatio = 0.6;
  EXPECT_LT(Accumulate(after).rms, kMaxNoiseRatio * Accumulate(before).rms);
}

TEST(Fusion, PartialOverlapKeepsTheRestUnchanged) {
  const StereoRig rig = TestRig();
  const sim::Renderer renderer(sim::MakePlaneScene(), rig);
  const Rigid3d pose0 = Looking(rig, {-40, 0, 0}, 10), pose1 = Looking(rig, {40, 0, 0}, -10);
  const std::vector<FusionView> views = {TruthView(renderer, "a", pose0, pose0, 0.03, 1),
                                         TruthView(renderer, "b", pose1, pose1, 0.03, 2)};
  FusionOptions options;
  options.smooth_radius_px = 0;  // exactly unchanged (the default smooths along the normal)
  const FusionResult r = FuseViews(views, options);
  SCOPED_TRACE(r.summary.BriefReport());
  ASSERT_EQ(r.summary.status, FusionStatus::kOk);
  ASSERT_GT(r.summary.passed_through, 1000);
  // The passed-through points follow the clusters, in view and grid order: all points outside
  // the overlap but those beside the plane's silhouette (absorbed or trimmed).
  size_t k = static_cast<size_t>(r.summary.clusters);
  int64_t at_border = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    const std::vector<uint16_t> border =
        BorderDistancePx(views[v].cloud, options.min_border_hole_px);
    for (size_t i = 0; i < views[v].cloud.valid.size(); ++i) {
      if (!views[v].cloud.valid[i] || r.overlap[v][i]) continue;
      if (border[i] < options.border_trim_px) {
        ++at_border;
        continue;
      }
      ASSERT_LT(k, r.fused.size());
      ASSERT_EQ(r.fused.points[k], views[v].world_from_sensor * views[v].cloud.cloud.points[i]);
      ASSERT_EQ(r.support[k], 1);
      ASSERT_EQ(r.view[k], v);  // the view it came from
      ++k;
    }
  }
  EXPECT_EQ(k, r.fused.size());
  // A centre came from its seed's view, one of the two.
  ASSERT_EQ(r.view.size(), r.fused.size());
  for (size_t c = 0; c < static_cast<size_t>(r.summary.clusters); ++c) ASSERT_LT(r.view[c], 2);
  EXPECT_GT(at_border, 0);
  EXPECT_EQ(r.summary.absorbed + r.summary.trimmed, at_border);
}

TEST(Fusion, MixedPixelsBesideAHoleDoNotSurviveWhereAnotherViewSawThePlace) {
  constexpr double kSigmaMm = 0.02;
  constexpr double kMixedOffsetMm = 0.6;  // along the ray, as a silhouette's mixed pixels
  constexpr double kMaxHeightMm = 10 * kSigmaMm;
  const StereoRig rig = TestRig();
  const sim::Renderer renderer(sim::MakePlaneScene(), rig);
  const Rigid3d pose0 = Looking(rig, {-25, 0, 0}, 15), pose1 = Looking(rig, {25, 0, 0}, -15);
  std::vector<FusionView> views = {TruthView(renderer, "a", pose0, pose0, kSigmaMm, 1),
                                   TruthView(renderer, "b", pose1, pose1, kSigmaMm, 2)};
  // A 30 x 30 hole in the middle of b's grid (inside the overlap); the ring of points beside it
  // pushed along their rays with normals tilted by 60 degrees.
  OrganizedPointCloud& g = views[1].cloud;
  const int c0 = g.width / 2 - 15, r0 = g.height / 2 - 15;
  for (int r = r0; r < r0 + 30; ++r) {
    for (int c = c0; c < c0 + 30; ++c) g.valid[g.index(c, r)] = 0;
  }
  const std::vector<uint16_t> border = BorderDistancePx(g, FusionOptions().min_border_hole_px);
  int mixed = 0;
  for (size_t i = 0; i < g.valid.size(); ++i) {
    if (!g.valid[i] || border[i] != 0) continue;
    Eigen::Vector3d& p = g.cloud.points[i];
    Eigen::Vector3d& n = g.cloud.normals[i];
    p *= 1 + kMixedOffsetMm / p.norm();
    const Eigen::Vector3d t = n.cross(Eigen::Vector3d::UnitX()).normalized();
    n = (n * std::cos(M_PI / 3) + t * std::sin(M_PI / 3)).normalized();
    ++mixed;
  }
  ASSERT_GT(mixed, 100);
  const FusionResult r = FuseViews(views);
  SCOPED_TRACE(r.summary.BriefReport());
  ASSERT_EQ(r.summary.status, FusionStatus::kOk);
  double max_height = 0;
  for (const Eigen::Vector3d& p : r.fused.points)
    max_height = std::max(max_height, std::abs(p.z()));
  EXPECT_LT(max_height, kMaxHeightMm);
  EXPECT_GE(r.summary.absorbed + r.summary.absorbed_clusters + r.summary.unassigned, mixed);
}

TEST(Fusion, ViewsOverlappingInOneQuadrantAreSearchedInsideTheFrameOnly) {
  // Two synthetic 40 x 40 pinhole grids of a plane (0.5 mm spacing at 100 mm), the second
  // shifted by half a frame in x and y: most points of the first project beside or above the
  // second's frame (pixel discs clamped to it; a disc beside the frame on row 0 once wrapped
  // the slot range), a quadrant overlaps.
  constexpr int kSize = 40;
  constexpr double kSpacingMm = 0.5, kDepthMm = 100;
  auto grid = [&](uint64_t seed) {
    OrganizedPointCloud g(kSize, kSize, true, true, true);
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> noise(0, 0.01);
    for (int r = 0; r < kSize; ++r) {
      for (int c = 0; c < kSize; ++c) {
        const size_t i = g.index(c, r);
        const Eigen::Vector3d ray((c - 19.5) * kSpacingMm / kDepthMm,
                                  (r - 19.5) * kSpacingMm / kDepthMm, 1);
        g.cloud.points[i] = ray * (kDepthMm + noise(rng));
        g.cloud.normals[i] = Eigen::Vector3d(0, 0, -1);
        g.cloud.quality[i] = 60.f;
        g.cloud.intensity[i] = 128.f;
        g.valid[i] = 1;
      }
    }
    return g;
  };
  const double shift_mm = kSize / 2 * kSpacingMm;
  const std::vector<FusionView> views = {
      {"a", grid(1), Rigid3d()},
      {"b", grid(2), Rigid3d(Eigen::Quaterniond::Identity(), {shift_mm, shift_mm, 0})}};
  const FusionResult r = FuseViews(views);
  SCOPED_TRACE(r.summary.BriefReport());
  ASSERT_EQ(r.summary.status, FusionStatus::kOk);
  // The overlapping quadrant (20 x 20 slots of each view) plus the points within the radius
  // (2 spacings) of its edges.
  EXPECT_GE(r.summary.overlap_points, 2 * 20 * 20);
  EXPECT_LE(r.summary.overlap_points, 2 * 23 * 23);
  EXPECT_LT(r.summary.max_fit_error_px, 0.01);
  EXPECT_EQ(
      r.summary.overlap_points + r.summary.passed_through + r.summary.absorbed + r.summary.trimmed,
      r.summary.input_points);
}

// Views too small for the grid projection's fit (< 100 points) are searched point by point,
// and their points' candidate centres are found without the own-view buckets: the fusion still
// merges the overlap into clusters from both views and accounts for every point.
TEST(Fusion, ViewsTooSmallForTheGridFitAreSearchedPointByPoint) {
  const StereoRig rig = TestRig();
  const sim::Renderer renderer(sim::MakePlaneScene(), rig);
  const Rigid3d pose0 = Looking(rig, {-25, 0, 0}, 15), pose1 = Looking(rig, {25, 0, 0}, -15);
  std::vector<FusionView> views = {TruthView(renderer, "a", pose0, pose0, 0.02, 1),
                                   TruthView(renderer, "b", pose1, pose1, 0.02, 2)};
  // Keep a 9 x 9 window: in view a at its image centre, in view b around the slot whose point
  // lies nearest to that place.
  constexpr int kHalf = 4;
  const OrganizedPointCloud& ga = views[0].cloud;
  const Eigen::Vector3d centre =
      views[0].world_from_sensor * ga.cloud.points[ga.index(ga.width / 2, ga.height / 2)];
  ASSERT_TRUE(ga.valid[ga.index(ga.width / 2, ga.height / 2)]);
  std::array<int, 2> col = {ga.width / 2, 0}, row = {ga.height / 2, 0};
  {
    const OrganizedPointCloud& gb = views[1].cloud;
    double best = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < gb.valid.size(); ++i) {
      if (!gb.valid[i]) continue;
      const double d = (views[1].world_from_sensor * gb.cloud.points[i] - centre).norm();
      if (d < best) {
        best = d;
        col[1] = static_cast<int>(i % gb.width);
        row[1] = static_cast<int>(i / gb.width);
      }
    }
    ASSERT_LT(best, 2.0);
  }
  for (size_t v = 0; v < 2; ++v) {
    OrganizedPointCloud& g = views[v].cloud;
    for (int r = 0; r < g.height; ++r) {
      for (int c = 0; c < g.width; ++c) {
        if (std::abs(c - col[v]) > kHalf || std::abs(r - row[v]) > kHalf)
          g.valid[g.index(c, r)] = 0;
      }
    }
    ASSERT_LT(g.NumValid(), 100u);
    ASSERT_GT(g.NumValid(), 50u);
  }
  const FusionResult r = FuseViews(views);
  SCOPED_TRACE(r.summary.BriefReport());
  ASSERT_EQ(r.summary.status, FusionStatus::kOk);
  EXPECT_EQ(r.summary.max_fit_error_px, 0);  // no view was fitted
  EXPECT_GT(r.summary.overlap_points, 20);
  int64_t two_view = 0;
  for (uint16_t n : r.support) two_view += n >= 2;
  EXPECT_GT(two_view, 5);
  EXPECT_EQ(
      r.summary.overlap_points + r.summary.passed_through + r.summary.absorbed + r.summary.trimmed,
      r.summary.input_points);
}

TEST(Fusion, DeterministicAndIndependentOfThreadCount) {
  const StereoRig rig = TestRig();
  const sim::Renderer renderer(sim::MakeSphereScene(30), rig);
  std::vector<FusionView> views;
  for (int v = 0; v < 3; ++v) {
    const double a = 2 * M_PI * v / 3;
    const Rigid3d pose = sim::SensorPoseLookingAt(
        rig, {0, 0, 30}, Eigen::Vector3d(std::cos(a), std::sin(a), 1.2).normalized());
    views.push_back(TruthView(renderer, std::to_string(v), pose, pose, 0.03, v + 1));
  }
  FusionOptions options;
  FusionResult one;
  {
    tbb::global_control serial(tbb::global_control::max_allowed_parallelism, 1);
    one = FuseViews(views, options);
  }
  ASSERT_EQ(one.summary.status, FusionStatus::kOk);
  const FusionResult many = FuseViews(views, options);
  const FusionResult again = FuseViews(views, options);
  for (const FusionResult* other : {&many, &again}) {
    ASSERT_EQ(one.fused.size(), other->fused.size());
    EXPECT_EQ(one.fused.points, other->fused.points);
    EXPECT_EQ(one.fused.normals, other->fused.normals);
    EXPECT_EQ(one.support, other->support);
    EXPECT_EQ(one.view, other->view);
  }
}

TEST(Fusion, BadInputsGiveTheirStatus) {
  const StereoRig rig = TestRig();
  const sim::Renderer renderer(sim::MakePlaneScene(), rig);
  const Rigid3d pose0 = Looking(rig, {-25, 0, 0}, 15), pose1 = Looking(rig, {25, 0, 0}, -15);
  const FusionView a = TruthView(renderer, "a", pose0, pose0, 0.02, 1);
  const FusionView b = TruthView(renderer, "b", pose1, pose1, 0.02, 2);

  EXPECT_EQ(FuseViews({}).summary.status, FusionStatus::kEmptyInput);
  FusionView empty = a;
  std::fill(empty.cloud.valid.begin(), empty.cloud.valid.end(), 0);
  EXPECT_EQ(FuseViews({empty}).summary.status, FusionStatus::kEmptyInput);

  FusionView no_normals = b;
  no_normals.cloud.cloud.normals.clear();
  const FusionResult r = FuseViews({a, no_normals});
  EXPECT_EQ(r.summary.status, FusionStatus::kMissingNormals);
  EXPECT_NE(r.summary.message.find("'b'"), std::string::npos) << r.summary.message;
  EXPECT_FALSE(r.summary.has_output());

  // The same view in metres.
  FusionView metres = b;
  for (auto& p : metres.cloud.cloud.points) p *= 1e-3;
  metres.world_from_sensor = Rigid3d(pose1.rotation(), pose1.translation() * 1e-3);
  EXPECT_EQ(FuseViews({a, metres}).summary.status, FusionStatus::kUnitsMismatch);

  FusionView bad_size = b;
  bad_size.cloud.cloud.quality.pop_back();
  EXPECT_EQ(FuseViews({a, bad_size}).summary.status, FusionStatus::kBadView);
  FusionView bad_pose = b;
  bad_pose.world_from_sensor =
      Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(std::nan(""), 0, 0));
  EXPECT_EQ(FuseViews({a, bad_pose}).summary.status, FusionStatus::kBadView);

  // One view alone passes through, but for the points beside its silhouette (mixed pixels in a
  // reconstruction), which are trimmed and counted; border_trim_px = 0 keeps every point.
  const FusionResult single = FuseViews({a});
  EXPECT_EQ(single.summary.status, FusionStatus::kNoOverlap);
  EXPECT_GT(single.summary.trimmed, 0);
  EXPECT_EQ(single.fused.size() + single.summary.trimmed, a.cloud.NumValid());
  EXPECT_NE(single.summary.message.find("trimmed"), std::string::npos) << single.summary.message;
  FusionOptions keep_all;
  keep_all.border_trim_px = 0;
  EXPECT_EQ(FuseViews({a}, keep_all).fused.size(), a.cloud.NumValid());
}

}  // namespace
}  // namespace fringe::fusion
