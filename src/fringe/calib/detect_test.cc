#include "fringe/calib/detect.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "fringe/calib/test_board.h"

namespace fringe::calib {
namespace {

CameraModel SmallCamera() {
  CameraModel cam;
  cam.width = 800;
  cam.height = 640;
  cam.fx = cam.fy = 1500;
  cam.cx = 399.5;
  cam.cy = 319.5;
  return cam;
}

struct Errors {
  double rms = 0, max = 0;
  int count = 0;
};

Errors CentreErrors(const TargetDetection& det, const CalibrationTarget& target,
                    const std::vector<Eigen::Vector2d>& truth) {
  Errors e;
  double ss = 0;
  for (const auto& f : det.features) {
    const double d = (f.centre_px - truth[f.row * target.cols + f.col]).norm();
    ss += d * d;
    e.max = std::max(e.max, d);
    ++e.count;
  }
  e.rms = e.count ? std::sqrt(ss / e.count) : 0;
  return e;
}

TEST(DetectionOptions, DefaultsPassCheck) { EXPECT_NO_THROW(DetectionOptions().Check()); }

// Rings under strong perspective: every feature found, ordered, and its true projected centre
// recovered (the ellipse centre would be off by ~0.1-0.3 px here).
TEST(DetectTarget, RingsUnderTiltTrueCentres) {
  constexpr double kMaxRmsPx = 0.03;
  constexpr double kMaxErrPx = 0.08;
  const CalibrationTarget target = CalibrationTarget::Reference();
  const CameraModel cam = SmallCamera();
  for (double tilt : {0.0, 35.0, 55.0}) {
    const Rigid3d pose = testing::LookAtBoard(target, 420, tilt, 30, 10);
    const cv::Mat img = testing::RenderTestBoard(target, cam, pose);
    const auto det = DetectTarget(img, target);
    ASSERT_TRUE(det.ok()) << "tilt " << tilt << ": " << det.BriefReport();
    const auto truth = testing::TrueCentres(target, cam, pose);
    int visible = 0;  // features well inside the image
    for (const auto& t : truth) visible += cam.InImage(t, 30) ? 1 : 0;
    EXPECT_GE(static_cast<int>(det.features.size()), visible) << det.BriefReport();
    const Errors e = CentreErrors(det, target, truth);
    std::cout << "tilt " << tilt << ": " << det.BriefReport() << ", centre rms " << e.rms
              << " px, max " << e.max << " px\n";
    EXPECT_LT(e.rms, kMaxRmsPx);
    EXPECT_LT(e.max, kMaxErrPx);
  }
}

TEST(DetectTarget, CirclesClutterAndOrientation) {
  CalibrationTarget target;
  target.type = TargetType::kCircleGrid;
  target.rows = 4;
  target.cols = 5;
  target.spacing_mm = 30;
  target.outer_radius_mm = 9;
  const CameraModel cam = SmallCamera();
  const Rigid3d pose = testing::LookAtBoard(target, 450, 30, 100, 160);
  cv::Mat img = testing::RenderTestBoard(target, cam, pose);
  // Clutter outside the board: a lone disc, a thin bar, a blob cluster.
  cv::circle(img, {40, 40}, 14, cv::Scalar(30), cv::FILLED, cv::LINE_AA);
  cv::line(img, {760, 20}, {780, 300}, cv::Scalar(20), 6);
  const auto det = DetectTarget(img, target);
  ASSERT_TRUE(det.ok()) << det.BriefReport();
  EXPECT_EQ(static_cast<int>(det.features.size()), target.NumFeatures());
  EXPECT_GE(det.rejected.size(), 1u);
  const auto truth = testing::TrueCentres(target, cam, pose);
  // Ordering: the symmetric grid may come back rotated by 180 degrees (then every feature maps
  // to (rows-1-r, cols-1-c)); it must be one of the two, never mirrored or shuffled.
  int direct = 0, rotated = 0;
  for (const auto& f : det.features) {
    if ((f.centre_px - truth[f.row * target.cols + f.col]).norm() < 1.0) ++direct;
    const int r2 = target.rows - 1 - f.row, c2 = target.cols - 1 - f.col;
    if ((f.centre_px - truth[r2 * target.cols + c2]).norm() < 1.0) ++rotated;
  }
  EXPECT_TRUE(direct == target.NumFeatures() || rotated == target.NumFeatures())
      << direct << " " << rotated;
}

// Partial board: the image cuts through the board; rings still ordered from the distinct L.
TEST(DetectTarget, PartialRingBoard) {
  const CalibrationTarget target = CalibrationTarget::Reference();
  const CameraModel cam = SmallCamera();
  const Rigid3d pose = testing::LookAtBoard(target, 330, 20, 0, 0, {50, 0});
  const cv::Mat img = testing::RenderTestBoard(target, cam, pose);
  const auto det = DetectTarget(img, target);
  ASSERT_TRUE(det.ok()) << det.BriefReport();
  const auto truth = testing::TrueCentres(target, cam, pose);
  int visible = 0;
  for (const auto& t : truth) visible += cam.InImage(t, 25) ? 1 : 0;
  EXPECT_LT(visible, target.NumFeatures());
  EXPECT_GE(static_cast<int>(det.features.size()), visible - 2);
  const Errors e = CentreErrors(det, target, truth);
  EXPECT_LT(e.max, 0.1);
}

// A ring board whose distinct features are hidden cannot be oriented: refused, not guessed.
TEST(DetectTarget, RefusesUnorderableBoard) {
  CalibrationTarget target = CalibrationTarget::Reference();
  CalibrationTarget printed = target;
  printed.distinct_features.clear();  // the image shows no centre dots
  const CameraModel cam = SmallCamera();
  const Rigid3d pose = testing::LookAtBoard(target, 420, 20, 0, 0);
  const cv::Mat img = testing::RenderTestBoard(printed, cam, pose);
  const auto det = DetectTarget(img, target);
  EXPECT_FALSE(det.ok());
  EXPECT_TRUE(det.features.empty());
  // A symmetric circle grid only partly visible is refused too.
  CalibrationTarget circles;
  circles.type = TargetType::kCircleGrid;
  circles.rows = 4;
  circles.cols = 5;
  circles.spacing_mm = 30;
  circles.outer_radius_mm = 9;
  const Rigid3d off = testing::LookAtBoard(circles, 300, 0, 0, 0, {-70, 0});
  const auto det2 = DetectTarget(testing::RenderTestBoard(circles, cam, off), circles);
  EXPECT_FALSE(det2.ok());
  EXPECT_TRUE(det2.features.empty());
  // Empty image.
  const cv::Mat flat(480, 640, CV_8U, cv::Scalar(128));
  EXPECT_FALSE(DetectTarget(flat, target).ok());
}

}  // namespace
}  // namespace fringe::calib

namespace fringe::calib {
namespace {

// Asymmetric grid (CalibrationTarget's layout): every feature at its true place, unambiguous.
TEST(DetectTarget, AsymmetricCircleGrid) {
  CalibrationTarget target;
  target.type = TargetType::kAsymmetricCircleGrid;
  target.rows = 7;
  target.cols = 4;
  target.spacing_mm = 30;
  target.outer_radius_mm = 6;
  const CameraModel cam = SmallCamera();
  for (double roll : {5.0, 185.0}) {
    const Rigid3d pose = testing::LookAtBoard(target, 450, 35, 30, roll);
    const cv::Mat img = testing::RenderTestBoard(target, cam, pose);
    const auto det = DetectTarget(img, target);
    ASSERT_TRUE(det.ok()) << det.BriefReport();
    ASSERT_EQ(static_cast<int>(det.features.size()), target.NumFeatures());
    const auto truth = testing::TrueCentres(target, cam, pose);
    int at_truth = 0;
    for (const auto& f : det.features) {
      if ((f.centre_px - truth[f.row * target.cols + f.col]).norm() < 0.5) ++at_truth;
    }
    EXPECT_EQ(at_truth, target.NumFeatures()) << "roll " << roll;
  }
}

}  // namespace
}  // namespace fringe::calib
