// Real image sets (../shared/data; see each folder's PROVENANCE.txt).
#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>

#include "fringe/calib/calibrate.h"
#include "fringe/io/image_io.h"
#include "fringe/testing/fringe_test.h"

namespace fringe::calib {
namespace {

CalibrationTarget Chessboard9x6() {
  CalibrationTarget t;
  t.type = TargetType::kChessboard;
  t.rows = 6;
  t.cols = 9;
  t.spacing_mm = 1.0;  // square size undocumented: units of one square
  return t;
}

// OpenCV's calibrateCamera on the same detections (default model k1 k2 p1 p2 k3).
double OpenCvRms(const std::vector<TargetDetection>& views, const CalibrationTarget& target,
                 cv::Size size, cv::Mat* k_out = nullptr) {
  std::vector<std::vector<cv::Point3f>> obj;
  std::vector<std::vector<cv::Point2f>> img;
  for (const auto& v : views) {
    if (!v.ok()) continue;
    obj.emplace_back();
    img.emplace_back();
    for (const auto& f : v.features) {
      const auto p = target.FeatureCentre(f.row, f.col);
      obj.back().emplace_back(p.x(), p.y(), 0.f);
      img.back().emplace_back(f.centre_px.x(), f.centre_px.y());
    }
  }
  cv::Mat k, d;
  std::vector<cv::Mat> r, t;
  const double rms = cv::calibrateCamera(obj, img, size, k, d, r, t);
  if (k_out) *k_out = k;
  return rms;
}

TEST(RealData, OpenCvChessboardMonoAndStereo) {
  FRINGE_SHARED_DATA_OR_SKIP(dir, "opencv-stereo-chessboard");
  const CalibrationTarget target = Chessboard9x6();
  std::vector<TargetDetection> left, right;
  std::vector<std::string> names;
  for (int i : {1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 13, 14}) {
    char l[32], r[32];
    std::snprintf(l, sizeof(l), "left%02d.jpg", i);
    std::snprintf(r, sizeof(r), "right%02d.jpg", i);
    left.push_back(DetectTarget(io::ReadGrayImage(dir / l), target));
    right.push_back(DetectTarget(io::ReadGrayImage(dir / r), target));
    names.push_back(l);
  }
  int found = 0;
  for (const auto& d : left) found += d.ok() ? 1 : 0;
  EXPECT_EQ(found, 13);
  CalibrationOptions options;
  options.estimate_k3 = true;      // OpenCV's default model
  options.max_image_rms_px = 100;  // compare on the same views and features: no rejection
  options.outlier_sigma = 1e9;
  const auto cal = CalibrateCamera(left, target, 640, 480, options, names);
  const double cv_rms = OpenCvRms(left, target, {640, 480});
  std::cout << "left: " << cal.summary.BriefReport() << "; OpenCV RMS " << cv_rms << "\n";
  std::cout << "fx " << cal.camera.fx << " cx " << cal.camera.cx << " cy " << cal.camera.cy << "\n";
  ASSERT_TRUE(cal.summary.ok());
  EXPECT_LE(cal.summary.final_rms_px, cv_rms + 1e-6);
  EXPECT_LT(cal.summary.final_rms_px, 0.45);
  const auto stereo = CalibrateStereo(left, right, target, 640, 480, options, names);
  std::cout << "stereo: " << stereo.BriefReport() << "\n";
  ASSERT_TRUE(stereo.summary.ok()) << stereo.summary.message;
  EXPECT_GE(stereo.num_pairs, 10);
  EXPECT_LT(stereo.rms_px, 0.6);
  EXPECT_LT(stereo.epipolar_rms_px, 0.6);
  // The baseline is about 3.3 squares (OpenCV's stereo_calib sample reports T ~ (-3.3, 0, 0)).
  EXPECT_NEAR(stereo.rig.BaselineMm(), 3.3, 0.3);
}

TEST(RealData, DiscocalThermalCircleGrid) {
  FRINGE_SHARED_DATA_OR_SKIP(dir, "discocal-circle-grid-thermal");
  CalibrationTarget target;
  target.type = TargetType::kCircleGrid;
  target.rows = 3;
  target.cols = 4;
  target.spacing_mm = 90;
  target.outer_radius_mm = 30;
  std::vector<TargetDetection> views;
  std::vector<std::string> names;
  for (int i = 0; i <= 24; ++i) {
    if (i == 4) continue;
    char n[40];
    std::snprintf(n, sizeof(n), "circle_8bit_%03d.png", i);
    views.push_back(DetectTarget(io::ReadGrayImage(dir / n), target));
    names.push_back(n);
    if (!views.back().ok()) std::cout << n << ": " << views.back().BriefReport() << "\n";
  }
  int found = 0;
  for (const auto& d : views) found += d.ok() ? 1 : 0;
  std::cout << "detected " << found << " of " << views.size() << "\n";
  EXPECT_GE(found, 20);
  CalibrationOptions options;
  options.estimate_k3 = true;
  const auto cal = CalibrateCamera(views, target, 640, 512, options, names);
  std::cout << cal.summary.BriefReport() << "\nfx " << cal.camera.fx << " fy " << cal.camera.fy
            << " cx " << cal.camera.cx << " cy " << cal.camera.cy << " k1 " << cal.camera.k1
            << " k2 " << cal.camera.k2 << " k3 " << cal.camera.k3 << "\n";
  for (const auto& v : cal.summary.views) {
    if (!v.message.empty()) std::cout << v.name << ": " << v.message << "\n";
  }
  ASSERT_TRUE(cal.summary.ok());
  // The authors' published result (calibration_result.yaml).
  constexpr double kFx = 440.724, kFy = 440.698, kCx = 308.749, kCy = 247.163;
  constexpr double kTol = 0.01;
  EXPECT_LT(std::abs(cal.camera.fx - kFx) / kFx, kTol);
  EXPECT_LT(std::abs(cal.camera.fy - kFy) / kFy, kTol);
  EXPECT_LT(std::abs(cal.camera.cx - kCx) / kCx, kTol);
  EXPECT_LT(std::abs(cal.camera.cy - kCy) / kCy, kTol);
  EXPECT_LE(cal.summary.final_rms_px, 0.2);
}

}  // namespace
}  // namespace fringe::calib
