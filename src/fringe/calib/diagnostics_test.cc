#include "fringe/calib/diagnostics.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

#include "fringe/calib/calibration_scene.h"
#include "fringe/testing/board.h"
#include "fringe/testing/report.h"
#include "fringe/util/error.h"
#include "fringe/util/random.h"

namespace fringe::calib {
namespace {

using testing::LookAtBoard;

// The reference rig at 640 x 512 (same field of view); chessboard detections made from the true
// projections plus Gaussian noise (no images: the diagnostics see only the calibration).
StereoRig SmallRig() {
  StereoRig rig = StereoRig::Reference();
  for (CameraModel* c : {&rig.left, &rig.right}) {
    c->width = 640;
    c->height = 512;
    c->fx /= 2;
    c->fy /= 2;
    c->cx = (c->cx + 0.5) / 2 - 0.5;
    c->cy = (c->cy + 0.5) / 2 - 0.5;
  }
  rig.projector.reset();
  return rig;
}

CalibrationTarget Chessboard() {
  CalibrationTarget t;
  t.type = TargetType::kChessboard;
  t.rows = 7;
  t.cols = 9;
  t.spacing_mm = 20;
  t.distinct_features.clear();
  return t;
}

constexpr double kNoisePx = 0.05;

TargetDetection Detect(const CameraModel& camera, const CalibrationTarget& target,
                       const Rigid3d& camera_from_board, util::Rng* rng) {
  std::normal_distribution<double> noise(0, kNoisePx);
  TargetDetection d;
  d.image_width = camera.width;
  d.image_height = camera.height;
  for (int r = 0; r < target.rows; ++r) {
    for (int c = 0; c < target.cols; ++c) {
      const Eigen::Vector3d p = camera_from_board * target.FeatureCentre(r, c);
      if (p.z() <= 0) continue;
      const Eigen::Vector2d px = camera.Project(p);
      if (px.x() < 2 || px.y() < 2 || px.x() > camera.width - 3 || px.y() > camera.height - 3) {
        continue;
      }
      FeatureObservation f;
      f.row = r;
      f.col = c;
      f.centre_px = px + Eigen::Vector2d(noise(*rng), noise(*rng));
      d.features.push_back(f);
    }
  }
  d.status = d.features.size() >= 6 ? DetectionStatus::kOk : DetectionStatus::kNotFound;
  return d;
}

struct Poses {
  std::vector<Rigid3d> left_from_board;
  std::vector<std::string> names;
};

// `count` poses at 450-600 mm with the given tilt (azimuth varying) and board offsets within
// +-offset_mm, so that the boards sweep the image.
Poses MakePoses(int count, double tilt_deg, double offset_mm, const CalibrationTarget& target,
                const Eigen::Vector2d& centre_offset_mm = {0, 0}) {
  Poses p;
  for (int i = 0; i < count; ++i) {
    const double a = 2 * M_PI * i / count;
    const Eigen::Vector2d offset =
        centre_offset_mm + offset_mm * Eigen::Vector2d(std::cos(a), std::sin(a));
    p.left_from_board.push_back(LookAtBoard(target, 450 + 150.0 * (i % 3) / 2, tilt_deg,
                                            360.0 * i / count, 10.0 * (i % 5) - 20, offset));
    p.names.push_back(util::StrCat("p", i < 10 ? "0" : "", i));
  }
  return p;
}

struct StereoDetections {
  std::vector<TargetDetection> left, right;
};

StereoDetections DetectBoth(const StereoRig& rig, const CalibrationTarget& target,
                            const Poses& poses, uint64_t seed) {
  util::Rng rng(seed);
  StereoDetections d;
  for (const Rigid3d& lfb : poses.left_from_board) {
    d.left.push_back(Detect(rig.left, target, lfb, &rng));
    d.right.push_back(Detect(rig.right, target, rig.right_from_left * lfb, &rng));
  }
  return d;
}

CalibrationDiagnostics DiagnoseStereo(const StereoCalibration& cal, const Poses& poses,
                                      const CalibrationTarget& target) {
  return DiagnoseCalibration({{"left", &cal.left}, {"right", &cal.right}}, poses.names, target,
                             {{"baseline", cal.rig.BaselineMm()}}, &cal);
}

TEST(Diagnostics, DefaultOptionsPassCheck) { EXPECT_NO_THROW(DiagnosticsOptions().Check()); }

TEST(Diagnostics, AGoodStereoCalibrationHasNoWarningAndReportsEveryPose) {
  const StereoRig rig = SmallRig();
  const CalibrationTarget target = Chessboard();
  const Poses poses = MakePoses(12, 35, 50, target);
  const StereoDetections det = DetectBoth(rig, target, poses, 1);
  const StereoCalibration cal = CalibrateStereo(det.left, det.right, target, 640, 512);
  ASSERT_TRUE(cal.summary.ok()) << cal.summary.message;
  const CalibrationDiagnostics d = DiagnoseStereo(cal, poses, target);
  EXPECT_TRUE(d.warnings.empty()) << d.BriefReport();
  EXPECT_TRUE(d.rejections.empty());
  EXPECT_EQ(d.used_poses, 12);
  ASSERT_EQ(d.poses.size(), 12u);
  ASSERT_EQ(d.devices.size(), 2u);
  // The residuals are the detection noise (2D RMS of sigma per axis).
  for (const DeviceDiagnostics& dev : d.devices) {
    EXPECT_NEAR(dev.rms_px, std::sqrt(2.0) * kNoisePx, 0.3 * kNoisePx) << dev.name;
    EXPECT_GT(dev.max_px, dev.rms_px);
    EXPECT_GT(dev.coverage, 0.5);
  }
  for (const PoseDiagnostics& p : d.poses) {
    EXPECT_TRUE(p.used);
    EXPECT_GT(p.rms_px[0], 0);
    EXPECT_NEAR(p.tilt_deg, 35, 1.0) << p.name;  // LookAtBoard tilts every pose by 35 deg
  }
  // The predicted depth sigma at the centre and the eight corners (its magnitude against the
  // spread over repeated calibrations: bench_calibration_predict). The centre is the volume's
  // best-determined point: no corner is predicted better.
  ASSERT_EQ(d.predicted_depth_sigma_mm.size(), 9u);
  EXPECT_EQ(d.predicted_depth_sigma_mm[0].where, "centre");
  for (const DepthSigma& s : d.predicted_depth_sigma_mm) {
    EXPECT_TRUE(std::isfinite(s.sigma_mm) && s.sigma_mm > 0) << s.where;
    EXPECT_GE(s.sigma_mm, d.predicted_depth_sigma_mm[0].sigma_mm) << s.where;
  }
  const nlohmann::json j = ToJson(d);
  EXPECT_EQ(j["poses"].size(), 12u);
  EXPECT_EQ(j["predicted_depth_sigma_mm"].size(), 9u);
  EXPECT_DOUBLE_EQ(j["devices"][1]["rms_px"].get<double>(), d.devices[1].rms_px);
  const std::string html =
      CalibrationReport(d, {{"left", &cal.left}, {"right", &cal.right}}).ToHtml();
  int sources = 0;
  // Per device a residual plot and a coverage map, and the predicted sigma map.
  EXPECT_EQ(io::testing::EmbeddedImages(html, &sources).size(), 5u);
  EXPECT_EQ(sources, 5);
}

// Twelve poses of the small rig; in pose p05 the board moved by 8 mm between the left and the
// right camera's exposures.
struct ShiftedPoseScene {
  StereoRig rig = SmallRig();
  CalibrationTarget target = Chessboard();
  Poses poses = MakePoses(12, 35, 50, target);
  StereoDetections det = DetectBoth(rig, target, poses, 2);
  ShiftedPoseScene() {
    util::Rng rng(3);
    const Rigid3d shifted =
        poses.left_from_board[5] * Rigid3d(Eigen::Matrix3d::Identity(), Eigen::Vector3d(8, 0, 0));
    det.right[5] = Detect(rig.right, target, rig.right_from_left * shifted, &rng);
  }
};

TEST(Diagnostics, APoseWithAShiftedBoardIsRejectedNamedAndKeptWithKeepAll) {
  // In pose p05 the board moved by 8 mm between the left and the right camera's exposures: its
  // joint residual is far above the others'.
  ShiftedPoseScene scene;
  const CalibrationTarget& target = scene.target;
  const Poses& poses = scene.poses;
  StereoDetections& det = scene.det;

  const StereoCalibration cal = CalibrateStereo(det.left, det.right, target, 640, 512);
  ASSERT_TRUE(cal.summary.ok()) << cal.summary.message;
  const CalibrationDiagnostics d = DiagnoseStereo(cal, poses, target);
  ASSERT_EQ(d.rejections.size(), 1u) << d.BriefReport();
  EXPECT_NE(d.rejections[0].find("pose p05"), std::string::npos) << d.rejections[0];
  EXPECT_NE(d.rejections[0].find("outlier among the poses"), std::string::npos);
  EXPECT_FALSE(d.poses[5].used);
  EXPECT_EQ(d.used_poses, 11);
  EXPECT_NEAR(d.devices[1].rms_px, std::sqrt(2.0) * kNoisePx, 0.3 * kNoisePx);

  CalibrationOptions keep_all;
  keep_all.reject_outlier_views = false;
  const StereoCalibration kept = CalibrateStereo(det.left, det.right, target, 640, 512, keep_all);
  ASSERT_TRUE(kept.summary.ok());
  const CalibrationDiagnostics k = DiagnoseStereo(kept, poses, target);
  EXPECT_TRUE(k.rejections.empty());
  EXPECT_TRUE(k.poses[5].used);
  // The shifted pose stands out in the per-pose table (its RMS is the largest), and keeping it
  // spoils the whole calibration.
  for (size_t i = 0; i < k.poses.size(); ++i) {
    if (i != 5) {
      EXPECT_GT(k.poses[5].rms_px[1], k.poses[i].rms_px[1]) << k.poses[i].name;
    }
  }
  EXPECT_GT(k.devices[1].rms_px, 5 * d.devices[1].rms_px);
}

TEST(Diagnostics, TranslationsInMetresAreWarnedAbout) {
  // The board's spacing given in metres (0.02 instead of 20 mm): the calibration converges with
  // every translation 1000 x too small, a 0.2 mm baseline.
  const StereoRig rig = SmallRig();
  const CalibrationTarget target = Chessboard();
  const Poses poses = MakePoses(10, 35, 50, target);
  const StereoDetections det = DetectBoth(rig, target, poses, 4);
  CalibrationTarget in_metres = target;
  in_metres.spacing_mm = target.spacing_mm / 1000;
  const StereoCalibration cal = CalibrateStereo(det.left, det.right, in_metres, 640, 512);
  ASSERT_TRUE(cal.summary.ok()) << cal.summary.message;
  EXPECT_NEAR(cal.rig.BaselineMm(), rig.BaselineMm() / 1000, 0.01 * rig.BaselineMm() / 1000);
  const CalibrationDiagnostics d = DiagnoseStereo(cal, poses, in_metres);
  EXPECT_TRUE(d.has_warning("distance")) << d.BriefReport();
  EXPECT_NE(d.warnings[0].find("metres"), std::string::npos) << d.warnings[0];
  // The focal lengths do not depend on the unit: no focal warning.
  EXPECT_FALSE(d.has_warning("focal"));
}

TEST(Diagnostics, FrontoParallelPosesAndFewPosesAreWarnedAbout) {
  const StereoRig rig = SmallRig();
  const CalibrationTarget target = Chessboard();
  const Poses flat = MakePoses(8, 0, 60, target);  // every board parallel to the sensor
  util::Rng rng(5);
  std::vector<TargetDetection> views;
  for (const Rigid3d& p : flat.left_from_board) views.push_back(Detect(rig.left, target, p, &rng));
  const CameraCalibration cal = CalibrateCamera(views, target, 640, 512);
  ASSERT_FALSE(cal.summary.views.empty());
  const CalibrationDiagnostics d =
      DiagnoseCalibration({{"camera", &cal}}, flat.names, target, {}, nullptr);
  EXPECT_TRUE(d.has_warning("no_tilt")) << d.BriefReport();
  EXPECT_LT(d.max_tilt_deg, 2.0);  // the estimated poses, not exactly the true 0 deg
  EXPECT_FALSE(d.has_warning("few_poses"));
  EXPECT_TRUE(d.predicted_depth_sigma_mm.empty());  // one camera: nothing to triangulate

  const Poses few = MakePoses(4, 35, 60, target);
  std::vector<TargetDetection> few_views;
  for (const Rigid3d& p : few.left_from_board) {
    few_views.push_back(Detect(rig.left, target, p, &rng));
  }
  const CameraCalibration few_cal = CalibrateCamera(few_views, target, 640, 512);
  ASSERT_TRUE(few_cal.summary.ok()) << few_cal.summary.message;
  const CalibrationDiagnostics f =
      DiagnoseCalibration({{"camera", &few_cal}}, few.names, target, {}, nullptr);
  EXPECT_TRUE(f.has_warning("few_poses")) << f.BriefReport();
  EXPECT_FALSE(f.has_warning("no_tilt"));
}

TEST(Diagnostics, ASensorCornerNeverCoveredShowsInTheMapAndWarns) {
  // Every board sits in the upper left of the image: the lower right corner sees nothing.
  const StereoRig rig = SmallRig();
  const CalibrationTarget target = Chessboard();
  const Poses poses = MakePoses(10, 30, 15, target, Eigen::Vector2d(60, 45));
  util::Rng rng(6);
  std::vector<TargetDetection> views;
  for (const Rigid3d& p : poses.left_from_board) {
    views.push_back(Detect(rig.left, target, p, &rng));
  }
  const CameraCalibration cal = CalibrateCamera(views, target, 640, 512);
  ASSERT_TRUE(cal.summary.ok()) << cal.summary.message;
  const CalibrationDiagnostics d =
      DiagnoseCalibration({{"camera", &cal}}, poses.names, target, {}, nullptr);
  ASSERT_EQ(d.devices.size(), 1u);
  const cv::Mat& map = d.devices[0].coverage_map;
  // The corner cell and its neighbourhood: covered by no pose.
  const cv::Rect corner(map.cols * 3 / 4, map.rows * 3 / 4, map.cols / 4, map.rows / 4);
  EXPECT_EQ(cv::countNonZero(map(corner)), 0);
  // The coverage is the fraction of covered cells, and the covered cells hold the boards: every
  // detected feature's cell, or a neighbour for a feature on a board's hull, is covered.
  EXPECT_DOUBLE_EQ(d.devices[0].coverage, double(cv::countNonZero(map)) / map.total());
  const double cell_px = 640.0 / DiagnosticsOptions().coverage_cells;
  for (const TargetDetection& v : views) {
    for (const FeatureObservation& f : v.features) {
      const int c = std::min(map.cols - 1, int(std::floor((f.centre_px.x() + 0.5) / cell_px)));
      const int r = std::min(map.rows - 1, int(std::floor((f.centre_px.y() + 0.5) / cell_px)));
      const cv::Rect around = cv::Rect(c - 1, r - 1, 3, 3) & cv::Rect(0, 0, map.cols, map.rows);
      EXPECT_GT(cv::countNonZero(map(around)), 0) << c << " " << r;
    }
  }
  EXPECT_LT(d.devices[0].coverage, 0.5);
  EXPECT_TRUE(d.has_warning("coverage")) << d.BriefReport();
}

TEST(Diagnostics, PredictedDepthSigmaOfAParallelRigFollowsTheBaselineLaw) {
  // Parallel cameras, baseline b along x, no distortion: z = f b / disparity, so an uncertain
  // baseline alone gives sigma_z = z sigma_b / b exactly to first order.
  StereoRig rig = SmallRig();
  for (CameraModel* c : {&rig.left, &rig.right}) {
    c->k1 = c->k2 = c->p1 = c->p2 = c->k3 = 0;
  }
  rig.right = rig.left;
  rig.right_from_left = Rigid3d(Eigen::Matrix3d::Identity(), Eigen::Vector3d(-200, 0, 0));
  Eigen::MatrixXd cov = Eigen::MatrixXd::Zero(24, 24);
  const double sigma_b = 0.1;
  cov(21, 21) = sigma_b * sigma_b;  // right_from_left translation x
  for (double z : {400.0, 500.0, 650.0}) {
    EXPECT_NEAR(PredictedDepthSigmaMm(rig, cov, Eigen::Vector3d(-100, 0, z)), z * sigma_b / 200,
                1e-3 * z * sigma_b / 200)
        << z;
  }
  // A covariance of the wrong size, or a point behind the camera: no prediction.
  EXPECT_TRUE(
      std::isnan(PredictedDepthSigmaMm(rig, Eigen::MatrixXd(), Eigen::Vector3d(0, 0, 500))));
  EXPECT_TRUE(std::isnan(PredictedDepthSigmaMm(rig, cov, Eigen::Vector3d(0, 0, -500))));
}

TEST(Diagnostics, TheReportsSceneHoldsTheUsedBoardsAndTheDevicesAtTheirPoses) {
  // Twelve poses, p05 with the board moved between the exposures (rejected): the 3D view of the
  // report holds the eleven used boards at their solved poses (within kPoseMm of the truth),
  // each with its pose's residual, and the right camera at the calibrated baseline.
  constexpr double kPoseMm = 0.5;  // solved board corners and camera centre against the truth
  ShiftedPoseScene shifted_scene;
  const StereoRig& rig = shifted_scene.rig;
  const CalibrationTarget& target = shifted_scene.target;
  const Poses& poses = shifted_scene.poses;
  StereoDetections& det = shifted_scene.det;
  const StereoCalibration cal = CalibrateStereo(det.left, det.right, target, 640, 512);
  ASSERT_TRUE(cal.summary.ok()) << cal.summary.message;
  const CalibrationDiagnostics d = DiagnoseStereo(cal, poses, target);
  ASSERT_FALSE(d.poses[5].used);
  const io::ReportScene scene =
      CalibrationScene(d, {{"left", &cal.left}, {"right", &cal.right}}, target);
  const nlohmann::json& s = scene.description;
  ASSERT_EQ(s["boards"].size(), 11u);
  const nlohmann::json& rms = s["colourings"][0];
  ASSERT_EQ(rms["id"], "pose_rms");
  size_t b = 0;
  for (size_t v = 0; v < poses.names.size(); ++v) {
    if (v == 5) continue;
    const nlohmann::json& board = s["boards"][b];
    EXPECT_EQ(board["name"], poses.names[v]);
    const Eigen::Vector3d corner(board["corners"][2][0].get<double>(),
                                 board["corners"][2][1].get<double>(),
                                 board["corners"][2][2].get<double>());
    const Eigen::Vector3d truth =
        poses.left_from_board[v] * target.FeatureCentre(target.rows - 1, target.cols - 1);
    EXPECT_LT((corner - truth).norm(), kPoseMm) << poses.names[v];
    const PoseDiagnostics& p = d.poses[v];
    const double expected = std::sqrt(
        (p.features[0] * p.rms_px[0] * p.rms_px[0] + p.features[1] * p.rms_px[1] * p.rms_px[1]) /
        (p.features[0] + p.features[1]));
    EXPECT_NEAR(rms["boards"][b].get<double>(), expected, 1e-12) << poses.names[v];
    ++b;
  }
  EXPECT_EQ(s["points"]["count"].get<size_t>(), 11u * target.rows * target.cols);
  ASSERT_EQ(s["views"].size(), 2u);
  EXPECT_EQ(s["views"][1]["name"], "right");
  const nlohmann::json& t = s["views"][1]["world_from_sensor"];
  const Eigen::Vector3d right_centre(t[3].get<double>(), t[7].get<double>(), t[11].get<double>());
  EXPECT_NEAR(right_centre.norm(), cal.rig.BaselineMm(), 1e-6);
  EXPECT_LT((right_centre - rig.right_from_left.Inverse().translation()).norm(), kPoseMm);
}

}  // namespace
}  // namespace fringe::calib
