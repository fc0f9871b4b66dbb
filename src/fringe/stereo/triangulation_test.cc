#include "fringe/stereo/triangulation.h"

#include <gtest/gtest.h>

#include <iostream>
#include <random>

#include "fringe/calib/calibrate.h"
#include "fringe/calib/detect.h"
#include "fringe/geometry/align.h"
#include "fringe/sim/board.h"
#include "fringe/util/random.h"

namespace fringe::stereo {
namespace {

TEST(Triangulation, DefaultOptionsPassCheck) { EXPECT_NO_THROW(TriangulationOptions().Check()); }

TEST(Triangulation, RoundTripInMeasuringVolume) {
  constexpr double kTolMm = 1e-6;
  constexpr double kTolPx = 1e-6;
  const StereoRig rig = StereoRig::Reference();
  std::uniform_real_distribution<double> xy(-100, 100), z(420, 580);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d p(xy(util::GlobalRng()), xy(util::GlobalRng()), z(util::GlobalRng()));
    const Eigen::Vector2d l = rig.left.Project(p);
    const Eigen::Vector2d r = rig.right.Project(rig.right_from_left * p);
    for (int iterations : {0, 2}) {
      TriangulationOptions options;
      options.refine_iterations = iterations;
      const TriangulatedPoint t = Triangulate(rig, l, r, options);
      ASSERT_TRUE(t.ok()) << ToString(t.status);
      EXPECT_LT((t.p_in_left - p).norm(), kTolMm);
      EXPECT_LT(t.reprojection_error_px, kTolPx);
    }
  }
}

TEST(Triangulation, RefinementLowersResidualUnderNoise) {
  constexpr double kNoisePx = 0.3;
  const StereoRig rig = StereoRig::Reference();
  std::normal_distribution<double> noise(0, kNoisePx);
  double sum_mid = 0, sum_opt = 0;
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3d p(10.0 * (i % 10) - 50, 7.0 * (i / 10) - 35, 500);
    const Eigen::Vector2d l =
        rig.left.Project(p) + Eigen::Vector2d(noise(util::GlobalRng()), noise(util::GlobalRng()));
    const Eigen::Vector2d r = rig.right.Project(rig.right_from_left * p) +
                              Eigen::Vector2d(noise(util::GlobalRng()), noise(util::GlobalRng()));
    TriangulationOptions mid;
    mid.refine_iterations = 0;
    const TriangulatedPoint a = Triangulate(rig, l, r, mid);
    const TriangulatedPoint b = Triangulate(rig, l, r);
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_LE(b.reprojection_error_px, a.reprojection_error_px + 1e-9);
    sum_mid += a.reprojection_error_px;
    sum_opt += b.reprojection_error_px;
  }
  EXPECT_LT(sum_opt, sum_mid);
}

TEST(Triangulation, ParallelRaysAreRejected) {
  const StereoRig rig = StereoRig::Reference();
  // A point at infinity: the same direction seen from both cameras.
  const Eigen::Vector3d d(0.05, -0.02, 1.0);
  const Eigen::Vector2d l = rig.left.Project(d);
  const Eigen::Vector2d r = rig.right.Project(rig.right_from_left.RotateDirection(d));
  EXPECT_EQ(Triangulate(rig, l, r).status, TriangulationStatus::kParallelRays);
}

TEST(Triangulation, PointBehindTheCamerasIsRejected) {
  const StereoRig rig = StereoRig::Reference();
  // Rays that diverge: left ray pointing far left, right ray far right.
  const Eigen::Vector2d l(0, 512), r(1279, 512);
  EXPECT_EQ(Triangulate(rig, l, r).status, TriangulationStatus::kBehindCamera);
}

}  // namespace
}  // namespace fringe::stereo

namespace fringe::stereo {
namespace {

// Issue 13: a rig calibrated from the scanner's simulated board images (the reference rig at
// full size, the simulator's default board-pose plan with the scan's 15 poses, read noise
// 1.5 DN) triangulates the working volume as the true rig does, up to one rigid transform of
// the sensor frame (which registration absorbs: every view moves alike). Its right_from_left
// rotation differs from the truth by ~2e-5 rad, within its standard deviation: that rotation is
// correlated with the principal points, so the rays, and the points, hardly change.
TEST(Triangulation, RigCalibratedFromBoardsTriangulatesTheWorkingVolume) {
  constexpr double kMaxVolumeRmsMm = 0.002;  // after the rigid alignment; view noise ~0.035 mm
  constexpr double kMaxVolumeMaxMm = 0.01;
  constexpr double kMaxRotationSigmas = 4;  // rotation error / its standard deviation
  const StereoRig truth = StereoRig::Reference();
  const CalibrationTarget target = CalibrationTarget::Reference();
  sim::BoardPoseOptions po;
  po.count = 15;
  const std::vector<Rigid3d> poses = sim::GenerateBoardPoses(truth, target, po);
  std::vector<calib::TargetDetection> left, right;
  for (size_t i = 0; i < poses.size(); ++i) {
    const sim::StereoBoardImages imgs = sim::RenderStereoBoard(truth, target, poses[i], {}, i);
    left.push_back(calib::DetectTarget(imgs.left.image, target));
    right.push_back(calib::DetectTarget(imgs.right.image, target));
  }
  const calib::StereoCalibration cal =
      calib::CalibrateStereo(left, right, target, truth.left.width, truth.left.height);
  ASSERT_TRUE(cal.summary.ok()) << cal.summary.message;
  const auto& sd = cal.extrinsic_std_dev;
  const double rotation_sd = Eigen::Vector3d(sd[0], sd[1], sd[2]).norm();
  ASSERT_GT(rotation_sd, 0);
  EXPECT_LT(Difference(cal.rig.right_from_left, truth.right_from_left).angle_rad,
            kMaxRotationSigmas * rotation_sd);
  // Points over the left image at 430-570 mm that the right camera sees, from their true pixels.
  std::vector<Eigen::Vector3d> measured, true_points;
  for (int iz = 0; iz <= 6; ++iz) {
    for (int iy = 0; iy <= 12; ++iy) {
      for (int ix = 0; ix <= 16; ++ix) {
        const Eigen::Vector2d l(20 + (truth.left.width - 40) * ix / 16.0,
                                20 + (truth.left.height - 40) * iy / 12.0);
        const Eigen::Vector3d p = truth.left.Ray(l) * (430 + 140 * iz / 6.0);
        const Eigen::Vector2d r = truth.right.Project(truth.right_from_left * p);
        if (!truth.right.InImage(r, 10)) continue;
        const TriangulatedPoint t = Triangulate(cal.rig, l, r);
        ASSERT_TRUE(t.ok());
        measured.push_back(t.p_in_left);
        true_points.push_back(p);
      }
    }
  }
  ASSERT_GT(measured.size(), 1000u);
  const RigidAlignment a = AlignRigid(measured, true_points);
  ASSERT_TRUE(a.ok()) << a.message;
  double worst = 0;
  for (size_t i = 0; i < measured.size(); ++i) {
    worst = std::max(worst, (a.b_from_a * measured[i] - true_points[i]).norm());
  }
  std::cout << cal.BriefReport() << "\nright_from_left rotation error "
            << Difference(cal.rig.right_from_left, truth.right_from_left).angle_rad
            << " rad (std dev " << rotation_sd << "); volume after rigid alignment RMS " << a.rms_mm
            << " mm, max " << worst << " mm\n";
  EXPECT_LT(a.rms_mm, kMaxVolumeRmsMm);
  EXPECT_LT(worst, kMaxVolumeMaxMm);
}

}  // namespace
}  // namespace fringe::stereo
