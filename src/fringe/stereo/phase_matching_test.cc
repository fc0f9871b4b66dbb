#include "fringe/stereo/phase_matching.h"

#include <gtest/gtest.h>

#include <tbb/task_arena.h>

#include <cmath>
#include <cstring>

#include "fringe/testing/low_gradient.h"
#include "fringe/testing/stereo_scene.h"
#include "fringe/util/error.h"

namespace fringe::stereo {
namespace {

using testing::Plane;
using testing::Scene;
using testing::Sphere;

constexpr double kRigScale = 0.25;  // 320x256 cameras keep the tests fast

PhaseImage Ph(const cv::Mat& phase) {
  PhaseImage p;
  p.phase = phase;
  return p;
}

struct Errors {
  double max_point_mm = 0;
  double rms_point_mm = 0;
  double max_right_px = 0;
  int points = 0;
};

// Compares matched points with the exact surface point of each left pixel and the matched right
// pixel with the true projection of that point.
Errors Compare(const StereoRig& rig, const testing::TrueView& truth, const MatchResult& m) {
  Errors e;
  double sum_sq = 0;
  for (size_t i = 0; i < m.cloud.valid.size(); ++i) {
    if (!m.cloud.valid[i]) continue;
    const Eigen::Vector3d& p = truth.p_in_left[i];
    const double d = (m.cloud.cloud.points[i] - p).norm();
    e.max_point_mm = std::max(e.max_point_mm, d);
    sum_sq += d * d;
    const int c = static_cast<int>(i % m.cloud.width), r = static_cast<int>(i / m.cloud.width);
    const cv::Vec2f q = m.right_px.at<cv::Vec2f>(r, c);
    const Eigen::Vector2d q_true = rig.right.Project(rig.right_from_left * p);
    e.max_right_px = std::max(e.max_right_px, (Eigen::Vector2d(q[0], q[1]) - q_true).norm());
    ++e.points;
  }
  e.rms_point_mm = e.points ? std::sqrt(sum_sq / e.points) : 0;
  return e;
}

// A 40 mm sphere 480 mm in front of the sensor, midway between the cameras, before a plane at
// 560 mm: occlusions, a grazing limb and a depth jump.
Scene SphereBeforePlane(const StereoRig& rig) {
  Scene scene;
  scene.spheres.push_back(
      {Eigen::Vector3d(0, 0, 480) + rig.right_from_left.Inverse().translation() / 2, 40});
  scene.planes.push_back({Eigen::Vector3d(0, 0, -1), -560});
  return scene;
}

int LitPixels(const cv::Mat& phase) {
  int n = 0;
  for (int r = 0; r < phase.rows; ++r) {
    for (int c = 0; c < phase.cols; ++c) n += std::isfinite(phase.at<float>(r, c));
  }
  return n;
}

TEST(PhaseMatching, DefaultOptionsPassCheck) { EXPECT_NO_THROW(MatchingOptions().Check()); }

TEST(PhaseMatching, TiltedPlaneRecoversKnownDisparities) {
  // Named tolerances: bilinear resampling of a smooth phase field leaves errors far below the
  // phase noise of real data (0.01 projector px ~ 0.005 mm here).
  constexpr double kMaxRightPxError = 0.01;
  constexpr double kMaxPointErrorMm = 0.01;
  constexpr double kMinCoverage = 0.9;
  const StereoRig rig = testing::ScaledReferenceRig(kRigScale);
  Scene scene;
  scene.planes.push_back({Eigen::Vector3d(0.2, -0.1, -1).normalized(), -500});
  const auto left = testing::TraceView(rig, scene, false);
  const auto right = testing::TraceView(rig, scene, true);
  for (auto interp : {CrossingInterpolation::kLinear, CrossingInterpolation::kCubic}) {
    MatchingOptions options;
    options.interpolation = interp;
    const MatchResult m = MatchPhase(rig, Ph(left.phase), Ph(right.phase), options);
    const Errors e = Compare(rig, left, m);
    SCOPED_TRACE(m.summary.BriefReport());
    EXPECT_EQ(e.points, m.summary.points);
    EXPECT_GT(e.points, kMinCoverage * LitPixels(left.phase));
    EXPECT_LT(e.max_right_px, kMaxRightPxError);
    EXPECT_LT(e.max_point_mm, kMaxPointErrorMm);
    EXPECT_LT(m.summary.mean_reprojection_error_px, 1e-3);
    EXPECT_EQ(m.summary.ambiguous, 0);
  }
}

TEST(PhaseMatching, SphereBeforePlaneHasNoWrongMatches) {
  // On the 4x downscaled rig one pixel of disparity is ~2.5 mm of depth, and at the grazing limb
  // of the sphere the bilinear resampling of the phase is least accurate: most points are exact,
  // a thin band at the limb is within kMaxLimbErrorMm, and no point is a wrong match.
  constexpr double kPointErrorMm = 0.02;
  constexpr double kMinFractionWithin = 0.98;
  constexpr double kMaxLimbErrorMm = 0.5;
  constexpr double kMinCoverage = 0.8;
  const StereoRig rig = testing::ScaledReferenceRig(kRigScale);
  const Scene scene = SphereBeforePlane(rig);
  const auto left = testing::TraceView(rig, scene, false);
  const auto right = testing::TraceView(rig, scene, true);
  MatchingOptions options;
  options.max_projector_error_px = 0.05;
  const MatchResult m = MatchPhase(rig, Ph(left.phase), Ph(right.phase), options);
  SCOPED_TRACE(m.summary.BriefReport());
  const Errors e = Compare(rig, left, m);
  EXPECT_GT(e.points, kMinCoverage * LitPixels(left.phase));
  EXPECT_LT(e.max_point_mm, kMaxLimbErrorMm);
  int within = 0;
  for (size_t i = 0; i < m.cloud.valid.size(); ++i) {
    within +=
        m.cloud.valid[i] && (m.cloud.cloud.points[i] - left.p_in_left[i]).norm() < kPointErrorMm;
  }
  EXPECT_GT(within, kMinFractionWithin * e.points);
  EXPECT_GT(m.summary.projector_inconsistent, 0);  // the occlusion ambiguities were seen
}

// The header promises results independent of the number of threads: one thread and an
// oversubscribed arena of 8 give bit-identical clouds, matches and counts.
TEST(PhaseMatching, IndependentOfThreadCount) {
  const StereoRig rig = testing::ScaledReferenceRig(kRigScale);
  const Scene scene = SphereBeforePlane(rig);
  const auto left = testing::TraceView(rig, scene, false);
  const auto right = testing::TraceView(rig, scene, true);
  MatchResult a, b;
  tbb::task_arena(1).execute([&] { a = MatchPhase(rig, Ph(left.phase), Ph(right.phase)); });
  tbb::task_arena(8).execute([&] { b = MatchPhase(rig, Ph(left.phase), Ph(right.phase)); });
  ASSERT_TRUE(a.summary.ok()) << a.summary.BriefReport();
  EXPECT_EQ(a.summary.points, b.summary.points);
  EXPECT_EQ(a.summary.ambiguous, b.summary.ambiguous);
  EXPECT_EQ(a.summary.no_crossing, b.summary.no_crossing);
  EXPECT_EQ(a.summary.mean_reprojection_error_px, b.summary.mean_reprojection_error_px);
  EXPECT_EQ(a.cloud.valid, b.cloud.valid);
  int differ = 0;
  for (size_t i = 0; i < a.cloud.valid.size(); ++i) {
    if (!a.cloud.valid[i]) continue;
    differ += std::memcmp(a.cloud.cloud.points[i].data(), b.cloud.cloud.points[i].data(),
                          3 * sizeof(double)) != 0;
  }
  EXPECT_EQ(differ, 0);
  ASSERT_TRUE(a.right_px.isContinuous() && b.right_px.isContinuous());
  ASSERT_EQ(a.right_px.size(), b.right_px.size());
  EXPECT_EQ(
      std::memcmp(a.right_px.data, b.right_px.data, a.right_px.total() * a.right_px.elemSize()),
      0);  // bytes, so that NaN slots compare equal
}

TEST(PhaseMatching, ViewWithoutValidPixelsGivesEmptyCloud) {
  const StereoRig rig = testing::ScaledReferenceRig(kRigScale);
  const cv::Mat nan(rig.left.height, rig.left.width, CV_32FC1,
                    cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  const MatchResult m = MatchPhase(rig, Ph(nan), Ph(nan.clone()));
  EXPECT_EQ(m.summary.status, MatchingStatus::kNoValidPixels);
  EXPECT_FALSE(m.summary.message.empty());
  EXPECT_EQ(m.summary.left_valid, 0);
  EXPECT_EQ(m.summary.points, 0);
  EXPECT_EQ(m.cloud.NumValid(), 0u);
  EXPECT_EQ(m.cloud.width, rig.left.width);
}

TEST(PhaseMatching, MaskAndModulationRejectPixels) {
  const StereoRig rig = testing::ScaledReferenceRig(kRigScale);
  Scene scene;
  scene.planes.push_back({Eigen::Vector3d(0, 0, -1), -500});
  const auto left = testing::TraceView(rig, scene, false);
  const auto right = testing::TraceView(rig, scene, true);
  PhaseImage l = Ph(left.phase);
  l.mask = cv::Mat(left.phase.size(), CV_8UC1, cv::Scalar(255));
  l.mask.colRange(0, l.mask.cols / 2).setTo(0);
  l.modulation = cv::Mat(left.phase.size(), CV_32FC1, cv::Scalar(50));
  l.modulation.rowRange(0, l.modulation.rows / 2).setTo(2);
  MatchingOptions options;
  options.min_modulation = 10;
  const MatchResult m = MatchPhase(rig, l, Ph(right.phase), options);
  ASSERT_GT(m.summary.points, 0);
  for (int r = 0; r < m.cloud.height; ++r) {
    for (int c = 0; c < m.cloud.width; ++c) {
      if (m.cloud.valid[m.cloud.index(c, r)]) {
        EXPECT_GE(c, m.cloud.width / 2);
        EXPECT_GE(r, m.cloud.height / 2);
        EXPECT_EQ(m.cloud.cloud.quality[m.cloud.index(c, r)], 50.f);
      }
    }
  }
}

TEST(PhaseMatching, WrongImageSizeThrows) {
  const StereoRig rig = testing::ScaledReferenceRig(kRigScale);
  const cv::Mat small(10, 10, CV_32FC1, cv::Scalar(0));
  EXPECT_THROW(MatchPhase(rig, Ph(small), Ph(small)), Error);
}

// The low-gradient view (test_low_gradient.h) on the quarter-size rig: 320x256 cameras, a
// 128x80 projector.
constexpr double kLowGradientCameraScale = 0.25;

TEST(PhaseMatching, LowPhaseGradientKeepsCoverage) {
  // Issue 10: with 0.2-0.35 projector px per camera pixel and sigma 1.5 DN, runs whose first
  // step is a noise step against the trend used to cover nothing, losing streaks of a row to the
  // left-right check.
  constexpr double kMinCoverage = 0.99;
  constexpr double kMaxLeftRightFraction = 0.01;
  // On the 4x downscaled rig a pixel of disparity is ~2.5 mm of depth; the phase noise
  // (0.07 projector px) over the gradient is ~0.25 px per camera, so the depth noise is ~1 mm.
  // A wrong crossing would be many pixels off.
  constexpr double kMaxRmsPointErrorMm = 1.5;
  constexpr double kMaxPointErrorMm = 8.0;
  const testing::LowGradientCase c =
      testing::MakeLowGradientCase(kLowGradientCameraScale, testing::kLowGradientModulationDn, 1.5);
  // The premise: the phase advances by 0.2-0.35 projector px per left pixel.
  const std::vector<float> gradient = testing::TruePhaseSteps(c);
  ASSERT_GT(gradient.size(), 100u);
  EXPECT_GT(gradient[gradient.size() / 20], 0.2f);
  EXPECT_LT(gradient[gradient.size() * 19 / 20], 0.35f);

  const MatchResult m = MatchPhase(c.rig, c.left, c.right);
  SCOPED_TRACE(m.summary.BriefReport());
  int matched = 0;
  const int eligible = testing::EligiblePixels(c, m, &matched);
  ASSERT_GT(eligible, c.rig.left.width * c.rig.left.height / 2);
  EXPECT_GE(static_cast<double>(matched) / eligible, kMinCoverage);
  EXPECT_LT(static_cast<double>(m.summary.lr_inconsistent) / m.summary.left_valid,
            kMaxLeftRightFraction);
  EXPECT_TRUE(m.summary.warning.empty());
  const Errors e = Compare(c.rig, c.left_truth, m);
  EXPECT_LT(e.rms_point_mm, kMaxRmsPointErrorMm);
  EXPECT_LT(e.max_point_mm, kMaxPointErrorMm);
}

TEST(PhaseMatching, MatchesDoNotDependOnThePhaseScale) {
  // Doubling every phase (as if the projector had twice the pixels) must give the same matches;
  // the projector check reads phase as a projector column, so it is off here.
  const testing::LowGradientCase c =
      testing::MakeLowGradientCase(kLowGradientCameraScale, testing::kLowGradientModulationDn, 1.5);
  MatchingOptions options;
  options.max_projector_error_px = 0;
  const MatchResult m1 = MatchPhase(c.rig, c.left, c.right, options);
  PhaseImage left2 = c.left, right2 = c.right;
  left2.phase = c.left.phase * 2;
  right2.phase = c.right.phase * 2;
  const MatchResult m2 = MatchPhase(c.rig, left2, right2, options);
  ASSERT_GT(m1.summary.points, 0);
  EXPECT_EQ(m1.summary.points, m2.summary.points);
  EXPECT_EQ(m1.summary.lr_inconsistent, m2.summary.lr_inconsistent);
  int differing = 0;
  for (size_t i = 0; i < m1.cloud.valid.size(); ++i) {
    differing += m1.cloud.valid[i] != m2.cloud.valid[i];
  }
  EXPECT_EQ(differing, 0);
}

// A rectified row whose phase advances by 0.28 projector px per sample with noise of 0.06 px,
// starting with a small step against the trend (the real capture of issue 10).
std::vector<float> SlowRow(int n, float scale) {
  std::vector<float> row(n);
  cv::RNG rng(3);
  for (int u = 0; u < n; ++u) row[u] = scale * static_cast<float>(0.28 * u + rng.gaussian(0.06));
  row[1] = row[0] - 0.05f * scale;
  return row;
}

TEST(PhaseMatching, SlowRowStartingAgainstTheTrendIsOneIncreasingRun) {
  // The run's direction comes from its net change, not from its first step: the whole row is
  // one increasing run. Before issue 10 the first step made it a decreasing run that never
  // turned (no step reversed by more than 0.5 px), so it covered nothing.
  for (const float scale : {1.0f, 2.0f, 0.25f}) {
    const auto runs = internal::RowRuns(SlowRow(600, scale), MatchingOptions());
    ASSERT_EQ(runs.size(), 1u) << "scale " << scale;
    EXPECT_TRUE(runs[0].increasing);
    EXPECT_LE(runs[0].begin, 1);
    EXPECT_EQ(runs[0].end, 599);
  }
}

TEST(PhaseMatching, RunsTurnAndBreakRelativeToTheLocalGradient) {
  // Up 0.3 px per sample for 100 samples, down for 100, a jump of 20 gradients, up again; the
  // same at 1/10 and 10x the phase scale.
  for (const float scale : {1.0f, 0.1f, 10.0f}) {
    std::vector<float> row;
    for (int u = 0; u < 100; ++u) row.push_back(scale * 0.3f * u);
    for (int u = 0; u < 100; ++u) row.push_back(scale * (30.0f - 0.3f * u));
    for (int u = 0; u < 100; ++u) row.push_back(scale * (6.0f + 0.3f * u));
    const auto runs = internal::RowRuns(row, MatchingOptions());
    ASSERT_EQ(runs.size(), 3u) << "scale " << scale;
    EXPECT_TRUE(runs[0].increasing);
    EXPECT_EQ(runs[0].begin, 0);
    EXPECT_EQ(runs[0].end, 100);  // the turning point (30, twice: samples 99 is 29.7)
    EXPECT_FALSE(runs[1].increasing);
    EXPECT_EQ(runs[1].begin, 100);
    EXPECT_EQ(runs[1].end, 199);  // the jump to 6 after 0.3 ends the run
    EXPECT_TRUE(runs[2].increasing);
    EXPECT_EQ(runs[2].begin, 200);
    EXPECT_EQ(runs[2].end, 299);
  }
}

TEST(PhaseMatching, ManyLeftRightRejectionsAreWarnedAbout) {
  // Right phase shifted by half a period against the left: crossings land elsewhere and the
  // left-right check fails widely; the summary must say so.
  const StereoRig rig = testing::ScaledReferenceRig(kRigScale);
  Scene scene;
  scene.planes.push_back({Eigen::Vector3d(0, 0, -1), -500});
  const auto left = testing::TraceView(rig, scene, false);
  const auto right = testing::TraceView(rig, scene, true);
  cv::Mat noisy_left = left.phase.clone();
  cv::RNG rng(7);
  cv::Mat noise(noisy_left.size(), CV_32F);
  rng.fill(noise, cv::RNG::NORMAL, 0, 3.0);  // far beyond the 1 px left-right tolerance
  noisy_left += noise;
  MatchingOptions options;
  options.max_projector_error_px = 0;
  const MatchResult m = MatchPhase(rig, Ph(noisy_left), Ph(right.phase), options);
  SCOPED_TRACE(m.summary.BriefReport());
  ASSERT_GT(m.summary.lr_inconsistent, options.lr_warning_fraction * m.summary.left_valid);
  EXPECT_NE(m.summary.warning.find("left-right"), std::string::npos);
  EXPECT_NE(m.summary.BriefReport().find("warning"), std::string::npos);
}

}  // namespace
}  // namespace fringe::stereo
