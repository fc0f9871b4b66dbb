#include "fringe/calib/projector.h"

#include <gtest/gtest.h>

#include <cmath>

#include "fringe/calib/projector_folder.h"
#include "fringe/io/image_io.h"
#include "fringe/sim/board.h"
#include "fringe/sim/projector_board.h"
#include "fringe/sim/renderer.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"

namespace fringe::calib {
namespace {

// The reference rig at half resolution (640 x 512 camera, 640 x 400 projector): the left
// camera and the projector, the projector with some lens distortion.
StereoRig HalfRig() {
  StereoRig rig = sim::ScaledRig(StereoRig::Reference(), 0.5);
  rig.projector->k1 = -0.05;
  rig.projector->k2 = 0.03;
  return rig;
}

struct Views {
  std::vector<TargetDetection> camera;
  std::vector<ProjectorCoordinates> coordinates;
  std::vector<std::vector<Eigen::Vector2d>> projector_truth;  // per view, row-major features
};

// Board poses seen by the camera and lit by the projector: the plain board image (detection)
// and the fringe stacks of both directions (decoded), as `fringe calibrate` would get them.
Views Simulate(const StereoRig& rig, const CalibrationTarget& target, int count) {
  const CameraModel& proj = *rig.projector;
  const auto schemes = sim::BothDirectionSchemes(proj);
  sim::BoardPoseOptions po;
  po.count = count;
  po.seed = 5;
  po.both_cameras = false;
  sim::FringeBoardOptions fb;
  fb.supersampling = 2;
  Views out;
  for (const Rigid3d& pose : sim::GenerateBoardPoses(rig, target, po)) {
    const uint64_t i = out.camera.size();
    out.camera.push_back(
        DetectTarget(sim::RenderBoardImage(rig.left, target, pose, {}, i).image, target));
    const auto d = sim::DecodeBoardUnderBothDirections(rig.left, proj, rig.projector_from_left,
                                                       target, pose, schemes, fb, i);
    out.coordinates.push_back({d[0].absolute_phase, d[1].absolute_phase, d[0].mask, d[1].mask});
    std::vector<Eigen::Vector2d> truth;
    for (int r = 0; r < target.rows; ++r) {
      for (int col = 0; col < target.cols; ++col) {
        truth.push_back(
            proj.Project(rig.projector_from_left * pose * target.FeatureCentre(r, col)));
      }
    }
    out.projector_truth.push_back(truth);
  }
  return out;
}

// Features mapped into the projector by local homographies land on the true projector pixels,
// and the joint calibration recovers the true projector and extrinsics.
TEST(ProjectorCalibration, SimulatedBoardsUnderBothFringeDirections) {
  constexpr double kMaxFeatureRmsPx = 0.05;  // mapped vs true projector feature centres
  // Half resolution, 6 views: a few times what was measured (0.005 %, 0.08 px, 0.005 deg,
  // 0.024 mm with 8 views); bench_camera_projector gives the full-resolution figures.
  constexpr double kMaxFocalErrPct = 0.03;
  constexpr double kMaxPrincipalErrPx = 0.3;
  constexpr double kMaxTranslationErrMm = 0.1;
  constexpr double kMaxRotationErrDeg = 0.015;
  constexpr double kMaxProjectorRmsPx = 0.1;
  const StereoRig rig = HalfRig();
  const CalibrationTarget target = CalibrationTarget::Reference();
  const Views views = Simulate(rig, target, 6);
  ProjectorFeatureOptions fo;
  fo.window_radius_px = 10;  // half resolution
  double ss = 0;
  int n = 0;
  for (size_t i = 0; i < views.camera.size(); ++i) {
    const TargetDetection d = MapFeaturesToProjector(
        views.camera[i], views.coordinates[i], rig.projector->width, rig.projector->height, fo);
    for (const auto& f : d.features) {
      ss += (f.centre_px - views.projector_truth[i][f.row * target.cols + f.col]).squaredNorm();
      ++n;
    }
  }
  ASSERT_GT(n, 100);
  const double feature_rms = std::sqrt(ss / n);
  const ProjectorCalibration cal = CalibrateCameraProjector(
      views.camera, views.coordinates, target, rig.left.width, rig.left.height,
      rig.projector->width, rig.projector->height, {}, fo);
  std::cout << n << " projector features, RMS " << feature_rms << " px vs truth\n"
            << cal.BriefReport() << "\n";
  EXPECT_LT(feature_rms, kMaxFeatureRmsPx);
  ASSERT_TRUE(cal.ok()) << cal.joint.summary.message;
  const CameraModel& p = *cal.rig.projector;
  const double focal_err_pct = 100 * std::abs(p.fx - rig.projector->fx) / rig.projector->fx;
  const double principal_err_px = std::hypot(p.cx - rig.projector->cx, p.cy - rig.projector->cy);
  const auto diff = Difference(cal.rig.projector_from_left, rig.projector_from_left);
  std::cout << "focal error " << focal_err_pct << " %, principal point " << principal_err_px
            << " px, rotation " << diff.angle_rad * 180 / M_PI << " deg, translation "
            << diff.translation_mm << " mm\n";
  EXPECT_EQ(p.width, rig.projector->width);
  EXPECT_EQ(p.height, rig.projector->height);
  EXPECT_LT(focal_err_pct, kMaxFocalErrPct);
  EXPECT_LT(principal_err_px, kMaxPrincipalErrPx);
  EXPECT_LT(diff.translation_mm, kMaxTranslationErrMm);
  EXPECT_LT(diff.angle_rad * 180 / M_PI, kMaxRotationErrDeg);
  EXPECT_LT(cal.projector_rms_px, kMaxProjectorRmsPx);
  EXPECT_EQ(cal.rig.BaselineMm(), 0.0);  // a camera-projector rig
}

// Two cameras + projector: both cameras see the boards under both fringe directions; the joint
// refinement of the three devices recovers the true rig (both cameras' extrinsics and the
// projector).
TEST(ProjectorCalibration, TwoCamerasAndProjectorRecoverTheTrueRig) {
  // Half resolution, 6 poses, as the camera + projector test above (its tolerances); the
  // stereo extrinsics as calibrate_test's stereo bounds at this scale.
  constexpr double kMaxFocalErrPct = 0.03;
  constexpr double kMaxPrincipalErrPx = 0.3;
  constexpr double kMaxTranslationErrMm = 0.1;
  constexpr double kMaxRotationErrDeg = 0.015;
  constexpr double kMaxRmsPx = 0.1;
  constexpr double kStereoSlack = 1.2;  // right_from_left vs the stereo-only calibration's error
  constexpr double kStereoFloorMm = 0.01, kStereoFloorDeg = 0.001;
  const StereoRig rig = HalfRig();
  const CameraModel& proj = *rig.projector;
  const CalibrationTarget target = CalibrationTarget::Reference();
  // Written as `fringe calibrate` reads it (DIR/KKK/left/, DIR/KKK/right/), calibrated through
  // the folder function: the layout, the reading and the joint refinement in one go.
  const test::TempDir tmp;
  sim::ProjectorCalibrationFolderOptions so;
  so.poses.count = 6;  // 4 poses miss the projector bounds (0.38 px principal point)
  so.poses.seed = 5;
  so.two_cameras = true;
  so.fringes.supersampling = 1;  // keeps the test short; the mono test above renders with 2
  sim::WriteProjectorCalibrationFolder(rig, target, tmp.path(), so);
  ProjectorFolderOptions fo;
  fo.features.window_radius_px = 10;  // half resolution
  const ProjectorFolderCalibration folder = CalibrateProjectorFolder(tmp.path(), target, fo);
  ASSERT_EQ(folder.layout, ProjectorFolderLayout::kCamerasProjector);
  ASSERT_EQ(folder.names.size(), 6u);
  EXPECT_TRUE(CalibrationToJson(folder).contains("right_from_left_std_dev"));
  const CamerasProjectorCalibration& cal = folder.cameras;
  // The plain board images of both cameras, for the stereo-only reference below.
  std::vector<TargetDetection> left, right;
  for (const std::string& name : folder.names) {
    left.push_back(DetectTarget(io::ReadGrayImage(tmp / name / "left" / "board.png"), target));
    right.push_back(DetectTarget(io::ReadGrayImage(tmp / name / "right" / "board.png"), target));
  }
  std::cout << cal.BriefReport() << "\n";
  ASSERT_TRUE(cal.ok()) << cal.joint.summary.message;
  const CameraModel& p = *cal.rig.projector;
  const double focal_err_pct = 100 * std::abs(p.fx - proj.fx) / proj.fx;
  const double principal_err_px = std::hypot(p.cx - proj.cx, p.cy - proj.cy);
  const auto dp = Difference(cal.rig.projector_from_left, rig.projector_from_left);
  const auto ds = Difference(cal.rig.right_from_left, rig.right_from_left);
  std::cout << "projector: focal error " << focal_err_pct << " %, principal point "
            << principal_err_px << " px, rotation " << dp.angle_rad * 180 / M_PI
            << " deg, translation " << dp.translation_mm << " mm; right camera: rotation "
            << ds.angle_rad * 180 / M_PI << " deg, translation " << ds.translation_mm << " mm\n";
  EXPECT_LT(focal_err_pct, kMaxFocalErrPct);
  EXPECT_LT(principal_err_px, kMaxPrincipalErrPx);
  EXPECT_LT(dp.translation_mm, kMaxTranslationErrMm);
  EXPECT_LT(dp.angle_rad * 180 / M_PI, kMaxRotationErrDeg);
  // The stereo extrinsics: as good as the two cameras calibrated without the projector (the
  // same detections; the projector's observations must not pull them off).
  const StereoCalibration stereo_only =
      CalibrateStereo(left, right, target, rig.left.width, rig.left.height);
  ASSERT_TRUE(stereo_only.summary.ok());
  const auto ds_only = Difference(stereo_only.rig.right_from_left, rig.right_from_left);
  std::cout << "right camera without the projector: rotation " << ds_only.angle_rad * 180 / M_PI
            << " deg, translation " << ds_only.translation_mm << " mm\n";
  EXPECT_LT(ds.translation_mm, kStereoSlack * ds_only.translation_mm + kStereoFloorMm);
  EXPECT_LT(ds.angle_rad, kStereoSlack * ds_only.angle_rad + kStereoFloorDeg * M_PI / 180);
  for (int d = 0; d < 3; ++d) EXPECT_LT(cal.joint.device_rms_px[d], kMaxRmsPx) << "device " << d;
  EXPECT_GT(cal.joint.extrinsic_std_dev[2][3], 0);  // standard deviations were estimated
  EXPECT_GT(cal.rig.BaselineMm(), 0);
  // Mismatched counts are refused.
  EXPECT_THROW(CalibrateCamerasProjector(left, {}, {}, {}, target, cv::Size(1, 1), cv::Size(1, 1),
                                         cv::Size(1, 1)),
               Error);
}

TEST(ProjectorCalibration, BadInputs) {
  ProjectorFeatureOptions small;
  small.window_radius_px = 1;
  EXPECT_THROW(small.Check(), Error);
  ProjectorCoordinates c;
  c.u = cv::Mat(10, 10, CV_32F, cv::Scalar(0));
  c.v = cv::Mat(10, 12, CV_32F, cv::Scalar(0));
  c.u_mask = c.v_mask = cv::Mat(10, 10, CV_8U, cv::Scalar(255));
  TargetDetection d;
  d.status = DetectionStatus::kOk;
  EXPECT_THROW(MapFeaturesToProjector(d, c, 100, 100), Error);
  c.v = c.u;
  // A window without any valid projector coordinate maps nothing.
  c.u_mask = cv::Mat(10, 10, CV_8U, cv::Scalar(0));
  FeatureObservation f;
  f.centre_px = Eigen::Vector2d(5, 5);
  d.features.assign(6, f);
  EXPECT_FALSE(MapFeaturesToProjector(d, c, 100, 100).ok());
  EXPECT_THROW(CalibrateCameraProjector({d}, {}, CalibrationTarget::Reference(), 10, 10, 100, 100),
               Error);
}

}  // namespace
}  // namespace fringe::calib
