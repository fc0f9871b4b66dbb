// The drift statistics on constructed data with a known answer: the projector residual's plane
// across the image (a roll or a shift along the optical axis tilts it while its mean stays at
// zero) and the markers' systematic epipolar residual against its own standard error (small
// markers scatter more; a fixed threshold would either flag their noise or miss a roll).
// End to end on rendered scans: scan_test.cc (pitch and yaw) and bench_calibration_check (every
// axis, 20 intact scans).
#include "fringe/pipeline/drift.h"

#include <gtest/gtest.h>

#include <random>

#include "fringe/sim/scan.h"
#include "fringe/util/error.h"

namespace fringe::pipeline {
namespace {

constexpr double kDepthMm = 510;  // the reference rig's working distance

TEST(DriftOptions, DefaultsPassCheck) {
  EXPECT_NO_THROW(DriftOptions().Check());
  DriftOptions o;
  o.max_projector_systematic_px = 0;
  EXPECT_THROW(o.Check(), Error);
  o = DriftOptions();
  o.min_epipolar_significance = -1;
  EXPECT_THROW(o.Check(), Error);
}

// A plane facing the quarter-size rig, its left phase the true projector column plus `tilt_px`
// times the normalised image row, noise and 2 % mismatches 20 px off.
struct ProjectorCase {
  StereoRig rig = sim::ScaledRig(StereoRig::Reference(), 0.25);
  OrganizedPointCloud cloud;
  cv::Mat phase;
  double tilt_rms_px = 0;  // RMS of the injected tilt over the points
};

ProjectorCase MakeProjectorCase(double tilt_px, uint64_t seed) {
  ProjectorCase c;
  const CameraModel& left = c.rig.left;
  c.cloud = OrganizedPointCloud(left.width, left.height);
  c.phase = cv::Mat(left.height, left.width, CV_32F, cv::Scalar(0));
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0, 0.05);
  std::uniform_real_distribution<double> uniform(0, 1);
  double sum2 = 0;
  int n = 0;
  for (int r = 0; r < left.height; ++r) {
    for (int col = 0; col < left.width; ++col) {
      const size_t i = c.cloud.index(col, r);
      const Eigen::Vector3d p = kDepthMm * left.Unproject({col, r}).homogeneous();
      const double tilt = tilt_px * (r - left.cy) / left.fy;
      double phi = c.rig.projector->Project(c.rig.projector_from_left * p).x() + tilt + noise(rng);
      const double u = uniform(rng);
      if (u < 0.02) phi += u < 0.01 ? 20 : -20;  // to both sides: the mean stays near zero
      c.cloud.cloud.points[i] = p;
      c.cloud.valid[i] = 1;
      c.phase.at<float>(r, col) = static_cast<float>(phi);
      sum2 += tilt * tilt;
      ++n;
    }
  }
  c.tilt_rms_px = std::sqrt(sum2 / n);
  return c;
}

TEST(Drift, ProjectorPlaneMeasuresATiltWhoseMeanIsZero) {
  constexpr double kMaxIntactSystematicPx = 0.003;  // noise 0.05 px over 20 k points: ~0.001
  constexpr double kTiltTolerance = 0.1;            // relative, the mismatches left out
  const DriftOptions options;
  {
    const ProjectorCase c = MakeProjectorCase(0, 1);
    ViewDrift d;
    MeasureProjectorConsistency(c.rig, c.cloud, c.phase, options, &d);
    DecideDrift(options, &d);
    EXPECT_TRUE(d.checked);
    EXPECT_LT(d.projector_systematic_px, kMaxIntactSystematicPx);
    EXPECT_FALSE(d.drift) << d.message;
  }
  // ~0.02 px RMS: what a 0.01 degree roll of the right camera gives on the reference rig.
  const ProjectorCase c = MakeProjectorCase(0.15, 2);
  ViewDrift d;
  MeasureProjectorConsistency(c.rig, c.cloud, c.phase, options, &d);
  DecideDrift(options, &d);
  EXPECT_GT(c.tilt_rms_px, options.max_projector_systematic_px);
  EXPECT_NEAR(d.projector_systematic_px, c.tilt_rms_px, kTiltTolerance * c.tilt_rms_px);
  // The mismatches would move a least-squares plane by ~20 px * sqrt(0.02 / n) = 0.01 px, as
  // much as the threshold; it is fitted without them.
  EXPECT_LT(std::abs(d.projector_bias_px), options.max_projector_bias_px);
  EXPECT_TRUE(d.drift);
  EXPECT_NE(d.message.find("across the image"), std::string::npos) << d.message;
}

// Markers over the full-size reference rig's image at the working distance: left centres exact,
// right centres projected by the TRUE rig plus noise, judged under `judged`.
ViewDrift MarkerVerdict(const StereoRig& truth, const StereoRig& judged, double noise_px,
                        uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0, noise_px);
  std::vector<registration::ViewMarker> markers;
  for (int gy = 0; gy < 4; ++gy) {
    for (int gx = 0; gx < 5; ++gx) {
      const Eigen::Vector2d left_px(truth.left.width * (0.1 + 0.2 * gx),
                                    truth.left.height * (0.2 + 0.2 * gy));
      const Eigen::Vector3d p = kDepthMm * truth.left.Unproject(left_px).homogeneous();
      registration::ViewMarker m;
      m.left_px = left_px;
      m.right_px =
          truth.right.Project(truth.right_from_left * p) + Eigen::Vector2d(noise(rng), noise(rng));
      markers.push_back(m);
    }
  }
  ViewDrift d;
  MeasureMarkerEpipolar(judged, markers, &d);
  DecideDrift(DriftOptions(), &d);
  return d;
}

TEST(Drift, MarkersFlagARollAndNotTheNoiseOfSmallMarkers) {
  const StereoRig truth = StereoRig::Reference();
  StereoRig rolled = truth;
  rolled.right_from_left =
      Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitZ(), 0.01 * M_PI / 180, Eigen::Vector3d::Zero()) *
      truth.right_from_left;
  const DriftOptions options;
  for (uint64_t seed = 1; seed <= 20; ++seed) {
    // Centres of ~12 px markers (0.11 px): their plane often exceeds the size threshold, never
    // significantly.
    const ViewDrift noisy = MarkerVerdict(truth, truth, 0.11, seed);
    EXPECT_TRUE(noisy.checked);
    EXPECT_FALSE(noisy.drift) << "seed " << seed << ": " << noisy.message;
    // ~25 px markers (0.03 px): the intact rig passes, the rolled one is flagged.
    EXPECT_FALSE(MarkerVerdict(truth, truth, 0.03, seed).drift) << "seed " << seed;
    const ViewDrift roll = MarkerVerdict(truth, rolled, 0.03, seed);
    EXPECT_TRUE(roll.drift) << "seed " << seed << ": " << roll.message;
    EXPECT_GT(roll.epipolar_systematic_px, options.max_epipolar_systematic_px);
  }
}

}  // namespace
}  // namespace fringe::pipeline
