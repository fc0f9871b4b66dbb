// RefineRig on synthetic correspondences with exact truth (no rendering: the points are
// projected by the true rig with Gaussian noise): a perturbed rig is recovered; what the data
// cannot determine (one flat view with the intrinsics free) or nothing redundant (a few markers,
// no projector) is refused with the rig unchanged.
#include "fringe/calib/refine_rig.h"

#include <gtest/gtest.h>

#include <random>

#include "fringe/util/error.h"

namespace fringe::calib {
namespace {

constexpr double kMarkerNoisePx = 0.03;  // marker centres on the reference rig (drift.h)
constexpr double kPhaseNoisePx = 0.02;   // decoded phase, projector pixels
// 3 views of 30 markers and 100 projector points each at these noises: the right camera's
// orientation to a few ten-thousandths of a degree; a 0.03 degree drift must come back below
// this.
constexpr double kMaxRotationErrDeg = 0.002;
constexpr double kMaxBaselineErrMm = 0.05;

double AngleDeg(const Rigid3d& a, const Rigid3d& b) {
  return a.rotation().angularDistance(b.rotation()) * 180 / M_PI;
}

StereoRig Drifted(const StereoRig& rig, double angle_deg) {
  StereoRig out = rig;
  const double a = angle_deg * M_PI / 180;
  const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  out.right_from_left = Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitX(), a, zero) *
                        Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitY(), a, zero) *
                        Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitZ(), a, zero) *
                        rig.right_from_left;
  return out;
}

// Views of points in a box in front of the rig (flat: all on one tilted plane), seen by both
// cameras: markers with noisy centres, phase points with noisy projector columns. Initial
// positions are the true ones (the refinement moves them with the rig).
RigRefinementData MakeData(const StereoRig& truth, int views, int markers, int points, bool flat,
                           uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> n(0, 1);
  RigRefinementData d;
  for (int v = 0; v < views; ++v) {
    auto sample = [&]() -> Eigen::Vector3d {
      const double x = 70 * u(rng), y = 55 * u(rng);
      const double z = flat ? 500 + 0.2 * x : 500 + 40 * u(rng) + 10 * v;
      return {x, y, z};
    };
    for (int i = 0; i < markers;) {
      const Eigen::Vector3d p = sample();
      const Eigen::Vector2d l = truth.left.Project(p),
                            r = truth.right.Project(truth.right_from_left * p);
      if (!truth.left.InImage(l, 5) || !truth.right.InImage(r, 5)) continue;
      d.markers.push_back({v, l + kMarkerNoisePx * Eigen::Vector2d(n(rng), n(rng)),
                           r + kMarkerNoisePx * Eigen::Vector2d(n(rng), n(rng)), p});
      ++i;
    }
    for (int i = 0; i < points && truth.projector;) {
      const Eigen::Vector3d p = sample();
      const Eigen::Vector2d l = truth.left.Project(p);
      const Eigen::Vector2d q = truth.projector->Project(truth.projector_from_left * p);
      if (!truth.left.InImage(l, 5) || !truth.projector->InImage(q, 5)) continue;
      // The left pixel is where the point was measured: exact; its phase carries the noise.
      d.points.push_back({v, l, q.x() + kPhaseNoisePx * n(rng), p});
      ++i;
    }
  }
  return d;
}

TEST(RigRefinementOptions, DefaultsPassCheck) {
  EXPECT_NO_THROW(RigRefinementOptions().Check());
  RigRefinementOptions o;
  o.phase_sigma_px = 0;
  EXPECT_THROW(o.Check(), Error);
}

// A right camera turned by 0.03 degrees about each axis: markers and projector columns bring it
// back with the projector held (the scale and the columns' reference); the residuals fall to
// the noise.
TEST(RefineRig, RecoversADriftedRightCamera) {
  const StereoRig truth = StereoRig::Reference();
  const StereoRig drifted = Drifted(truth, 0.03);
  ASSERT_GT(AngleDeg(drifted.right_from_left, truth.right_from_left), 0.05);
  const RigRefinementData data = MakeData(truth, 3, 30, 100, false, 7);
  RigRefinementOptions o;
  o.scale = RefineScale::kProjector;
  o.marker_sigma_px = kMarkerNoisePx;
  o.phase_sigma_px = kPhaseNoisePx;
  const RigRefinement r = RefineRig(drifted, data, o);
  ASSERT_TRUE(r.summary.ok()) << r.summary.BriefReport();
  const double err = AngleDeg(r.rig.right_from_left, truth.right_from_left);
  EXPECT_LT(err, kMaxRotationErrDeg) << r.summary.BriefReport();
  EXPECT_NEAR(r.rig.BaselineMm(), truth.BaselineMm(), kMaxBaselineErrMm);
  EXPECT_GT(r.summary.marker_epipolar_rms_before_px, 10 * r.summary.marker_epipolar_rms_after_px);
  EXPECT_LT(r.summary.marker_epipolar_rms_after_px, 2 * kMarkerNoisePx);
  // Every refined parameter is reported with a finite, positive uncertainty.
  ASSERT_FALSE(r.summary.parameters.empty());
  for (const RefinedParameter& p : r.summary.parameters) {
    EXPECT_GT(p.sigma, 0) << p.name;
    EXPECT_TRUE(std::isfinite(p.after)) << p.name;
  }
  // The rotation error is consistent with the stated uncertainty (a few sigmas).
  double sigma_deg = 0;
  for (const RefinedParameter& p : r.summary.parameters) {
    if (p.name.rfind("right_from_left rotation", 0) == 0) sigma_deg = std::max(sigma_deg, p.sigma);
  }
  EXPECT_LT(err, 5 * std::sqrt(3.0) * sigma_deg);
}

// One flat view with the intrinsics free: focal lengths and depth trade off on a plane; the
// refinement says which parameters are not determined and leaves the rig as it was.
TEST(RefineRig, OneFlatViewWithFreeIntrinsicsIsNotDetermined) {
  const StereoRig truth = StereoRig::Reference();
  StereoRig rig = Drifted(truth, 0.03);
  rig.projector.reset();
  RigRefinementData data = MakeData(truth, 1, 40, 0, true, 3);
  RigRefinementOptions o;
  o.intrinsics = true;
  const RigRefinement r = RefineRig(rig, data, o);
  EXPECT_EQ(r.summary.status, RefineStatus::kNotDetermined) << r.summary.BriefReport();
  EXPECT_NE(r.summary.message.find("do not determine"), std::string::npos) << r.summary.message;
  EXPECT_NE(r.summary.message.find("rig is unchanged"), std::string::npos);
  EXPECT_EQ(r.rig.right_from_left.translation(), rig.right_from_left.translation());
  EXPECT_EQ(r.rig.right_from_left.rotation().coeffs(), rig.right_from_left.rotation().coeffs());
  EXPECT_EQ(r.rig.left, rig.left);
  EXPECT_EQ(r.rig.right, rig.right);
}

// No projector and too few markers: nothing redundant, nothing refined.
TEST(RefineRig, NoRedundantEvidenceLeavesTheRigUnchanged) {
  StereoRig rig = StereoRig::Reference();
  rig.projector.reset();
  const RigRefinementData data = MakeData(rig, 1, 3, 0, false, 5);
  const RigRefinement r = RefineRig(rig, data);
  EXPECT_EQ(r.summary.status, RefineStatus::kNoEvidence);
  EXPECT_NE(r.summary.message.find("nothing constrains the rig"), std::string::npos);
  EXPECT_EQ(r.rig.right_from_left.translation(), rig.right_from_left.translation());
}

}  // namespace
}  // namespace fringe::calib
