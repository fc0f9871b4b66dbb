#include "fringe/calib/calibrate.h"

#include <gtest/gtest.h>

#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "fringe/calib/calibrate_folder.h"
#include "fringe/sim/board.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::calib {
namespace {

// The reference rig scaled to 640 x 512 (same field of view), to keep tests quick.
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
  rig.left.k1 = -0.12;
  rig.left.k2 = 0.15;
  rig.projector.reset();
  return rig;
}

struct SimViews {
  std::vector<TargetDetection> left, right;
  std::vector<std::vector<Eigen::Vector2d>> truth_left;
  std::vector<Rigid3d> left_from_board;
};

SimViews Simulate(const StereoRig& rig, const CalibrationTarget& target, int count, bool stereo,
                  uint64_t seed, bool full_board = false) {
  sim::BoardPoseOptions po;
  if (full_board) {  // symmetric grids are only detected whole
    po.min_visible_fraction = 1.0;
    po.min_distance_mm = 520;
    po.max_distance_mm = 700;
  }
  po.count = count;
  po.seed = seed;
  po.both_cameras = stereo;
  SimViews out;
  out.left_from_board = sim::GenerateBoardPoses(rig, target, po);
  for (size_t i = 0; i < out.left_from_board.size(); ++i) {
    const auto imgs = sim::RenderStereoBoard(rig, target, out.left_from_board[i], {}, i);
    out.left.push_back(DetectTarget(imgs.left.image, target));
    out.truth_left.push_back(imgs.left.centres_px);
    if (stereo) out.right.push_back(DetectTarget(imgs.right.image, target));
  }
  return out;
}

double RelErr(double a, double b) { return std::abs(a - b) / std::abs(b); }

TEST(CalibrationOptions, DefaultsPassCheck) { EXPECT_NO_THROW(CalibrationOptions().Check()); }

// Rings, 10 simulated views (tilts up to 60 deg, sigma 1.5 DN): intrinsics recovered.
TEST(CalibrateCamera, RingsRoundTrip) {
  constexpr double kMaxFocalErr = 1e-4;     // relative
  constexpr double kMaxCentreRmsPx = 0.01;  // final centres vs true projected centres
  constexpr double kMaxPrincipalErrPx = 0.5;
  constexpr double kMaxRmsPx = 0.05;
  const StereoRig rig = SmallRig();
  const CalibrationTarget target = CalibrationTarget::Reference();
  const SimViews sv = Simulate(rig, target, 10, false, 3);
  int detected = 0;
  for (const auto& d : sv.left) detected += d.ok() ? 1 : 0;
  EXPECT_GE(detected, 9);
  const auto cal = CalibrateCamera(sv.left, target, 640, 512);
  std::cout << cal.summary.BriefReport() << "\n";
  ASSERT_TRUE(cal.summary.ok()) << cal.summary.BriefReport();
  const CameraModel& c = cal.camera;
  std::cout << "fx " << c.fx << " (" << rig.left.fx << ") fy " << c.fy << " cx " << c.cx << " ("
            << rig.left.cx << ") cy " << c.cy << " (" << rig.left.cy << ") k1 " << c.k1 << " k2 "
            << c.k2 << " std fx " << cal.std_dev[0] << "\n";
  EXPECT_LT(RelErr(c.fx, rig.left.fx), kMaxFocalErr);
  EXPECT_LT(RelErr(c.fy, rig.left.fy), kMaxFocalErr);
  EXPECT_LT(std::abs(c.cx - rig.left.cx), kMaxPrincipalErrPx);
  EXPECT_LT(std::abs(c.cy - rig.left.cy), kMaxPrincipalErrPx);
  EXPECT_NEAR(c.k1, rig.left.k1, 0.01);
  EXPECT_LT(cal.summary.final_rms_px, kMaxRmsPx);
  EXPECT_GT(cal.std_dev[0], 0);
  // Measured centres against the true projected centres.
  double ss = 0;
  int n = 0;
  for (size_t v = 0; v < sv.left.size(); ++v) {
    for (size_t k = 0; k < cal.centres_px[v].size(); ++k) {
      const auto& f = sv.left[v].features[k];
      ss += (cal.centres_px[v][k] - sv.truth_left[v][f.row * target.cols + f.col]).squaredNorm();
      ++n;
    }
  }
  std::cout << "centre rms vs truth " << std::sqrt(ss / n) << " px over " << n << "\n";
  EXPECT_LT(std::sqrt(ss / n), kMaxCentreRmsPx);
}

// Solid circles, stereo: the ellipse centres are biased under perspective; the pose-based
// correction removes the bias, and the joint refinement recovers the baseline.
TEST(CalibrateStereo, CirclesRoundTripRemovesBias) {
  constexpr double kMaxFocalErr = 2e-4;       // relative
  constexpr double kMaxBaselineErrMm = 0.02;  // of 200 mm
  constexpr double kMaxAngleErrRad = 1e-4;
  constexpr double kMaxCentreRmsPx = 0.01;
  const StereoRig rig = SmallRig();
  CalibrationTarget target = CalibrationTarget::Reference();
  target.type = TargetType::kCircleGrid;
  const SimViews sv = Simulate(rig, target, 8, true, 11, true);
  const auto cal = CalibrateStereo(sv.left, sv.right, target, 640, 512);
  std::cout << cal.BriefReport() << "\n";
  ASSERT_TRUE(cal.summary.ok()) << cal.summary.message;
  EXPECT_GE(cal.num_pairs, 5);
  EXPECT_LT(RelErr(cal.rig.left.fx, rig.left.fx), kMaxFocalErr);
  EXPECT_LT(RelErr(cal.rig.right.fy, rig.right.fy), kMaxFocalErr);
  EXPECT_LT(std::abs(cal.rig.BaselineMm() - rig.BaselineMm()), kMaxBaselineErrMm);
  EXPECT_LT(Difference(cal.rig.right_from_left, rig.right_from_left).angle_rad, kMaxAngleErrRad);
  EXPECT_LT(cal.epipolar_rms_px, 0.02);
  double ss_final = 0, ss_raw = 0;
  int n = 0;
  for (size_t v = 0; v < sv.left.size(); ++v) {
    for (size_t k = 0; k < cal.left.centres_px[v].size(); ++k) {
      const auto& f = sv.left[v].features[k];
      const Eigen::Vector2d truth = sv.truth_left[v][f.row * target.cols + f.col];
      ss_final += (cal.left.centres_px[v][k] - truth).squaredNorm();
      ss_raw += (f.centre_px - truth).squaredNorm();
      ++n;
    }
  }
  const double final_rms = std::sqrt(ss_final / n), raw_rms = std::sqrt(ss_raw / n);
  std::cout << "circle centres vs truth: ellipse centres " << raw_rms << " px, corrected "
            << final_rms << " px\n";
  EXPECT_LT(final_rms, kMaxCentreRmsPx);
  EXPECT_GT(raw_rms, 3 * final_rms);
}

// With feature and view rejection off, a robust loss keeps gross centre errors from biasing
// the intrinsics; a solve cut short by the iteration limit is a reported failure.
TEST(CalibrateCamera, RobustLossResistsGrossErrorsAndNonConvergenceFails) {
  constexpr double kMaxRobustFocalErr = 2e-4;  // relative
  constexpr double kMinImprovement = 3;        // plain error / robust error
  const StereoRig rig = SmallRig();
  const CalibrationTarget target = CalibrationTarget::Reference();
  SimViews sv = Simulate(rig, target, 8, false, 5);
  int corrupted = 0;
  for (auto& d : sv.left) {
    for (size_t k = 0; k < d.features.size(); ++k) {
      auto& f = d.features[k];
      // No edge points: no re-measurement, the centres stay as given.
      f.outer_edge_px.clear();
      f.inner_edge_px.clear();
      if (k % 13 == 0) {
        f.centre_px += Eigen::Vector2d(3, -2);
        ++corrupted;
      }
    }
  }
  EXPECT_GT(corrupted, 20);
  CalibrationOptions options;
  options.outlier_sigma = 1e9;
  options.max_image_rms_px = 100;
  const auto plain = CalibrateCamera(sv.left, target, 640, 512, options);
  options.loss = RobustLoss::kCauchy;
  options.loss_scale_px = 0.1;
  const auto robust = CalibrateCamera(sv.left, target, 640, 512, options);
  std::cout << "plain: " << plain.summary.BriefReport()
            << "\nrobust: " << robust.summary.BriefReport() << "\n";
  ASSERT_TRUE(plain.summary.ok()) << plain.summary.message;
  ASSERT_TRUE(robust.summary.ok()) << robust.summary.message;
  EXPECT_EQ(robust.summary.solve.termination, ceres::CONVERGENCE);
  const double plain_err = RelErr(plain.camera.fx, rig.left.fx);
  const double robust_err = RelErr(robust.camera.fx, rig.left.fx);
  std::cout << "focal error: plain " << plain_err << ", Cauchy " << robust_err << "\n";
  EXPECT_LT(robust_err, kMaxRobustFocalErr);
  EXPECT_GT(plain_err, kMinImprovement * robust_err);

  options.max_iterations = 1;
  const auto cut = CalibrateCamera(sv.left, target, 640, 512, options);
  EXPECT_FALSE(cut.summary.ok());
  EXPECT_EQ(cut.summary.status, CalibrationStatus::kNotConverged);
  EXPECT_EQ(cut.summary.solve.termination, ceres::NO_CONVERGENCE);
  EXPECT_NE(cut.summary.message.find("did not converge"), std::string::npos) << cut.summary.message;
}

TEST(CalibrationOptions, LossScaleChecked) {
  CalibrationOptions o;
  o.loss_scale_px = 0;
  EXPECT_THROW(o.Check(), Error);
}

TEST(CalibrateCamera, TooFewViewsIsAStatus) {
  const CalibrationTarget target = CalibrationTarget::Reference();
  std::vector<TargetDetection> views(2);
  const auto cal = CalibrateCamera(views, target, 640, 512);
  EXPECT_FALSE(cal.summary.ok());
  EXPECT_EQ(cal.summary.status, CalibrationStatus::kTooFewViews);
  EXPECT_FALSE(cal.summary.message.empty());
}

}  // namespace
}  // namespace fringe::calib

namespace fringe::calib {
namespace {

// --centres: every detected centre of a folder calibration, raw and bias-corrected, with its
// view and board index. Solid circles: the raw ellipse centres are biased under perspective and
// the corrected ones are not, which the table must show against the true projected centres.
TEST(CalibrateFolder, CentresTableHoldsRawAndCorrectedCentres) {
  constexpr int kViews = 6;
  const StereoRig rig = SmallRig();
  CalibrationTarget target = CalibrationTarget::Reference();
  target.type = TargetType::kCircleGrid;
  sim::BoardPoseOptions po;
  po.count = kViews;
  po.seed = 5;
  po.both_cameras = false;
  po.min_visible_fraction = 1.0;  // symmetric grids are only detected whole
  po.min_distance_mm = 520;
  po.max_distance_mm = 700;
  test::TempDir tmp;
  std::vector<std::vector<Eigen::Vector2d>> truth;
  const auto poses = sim::GenerateBoardPoses(rig, target, po);
  for (size_t i = 0; i < poses.size(); ++i) {
    const sim::BoardImage img = sim::RenderBoardImage(rig.left, target, poses[i], {}, i);
    cv::imwrite((tmp / util::StrCat("view", i, ".png")).string(), img.image);
    truth.push_back(img.centres_px);
  }
  const FolderCalibration cal = CalibrateFolder(tmp.path(), target);
  ASSERT_TRUE(cal.success()) << cal.mono.summary.message;
  WriteCentres(tmp / "centres.json", cal, target);
  WriteCentres(tmp / "centres.csv", cal, target);
  EXPECT_THROW(WriteCentres(tmp / "centres.txt", cal, target), Error);
  EXPECT_FALSE(std::filesystem::exists(tmp / "centres.txt"));

  const nlohmann::json j = nlohmann::json::parse(util::ReadTextFile(tmp / "centres.json"));
  EXPECT_EQ(j.at("format"), "fringe-centres");
  size_t detected = 0;
  for (const auto& d : cal.left) detected += d.features.size();
  ASSERT_EQ(j.at("centres").size(), detected);
  ASSERT_GT(detected, 0u);
  double ss_raw = 0, ss_corrected = 0;
  int n = 0;
  for (const auto& c : j.at("centres")) {
    EXPECT_EQ(c.at("camera"), "camera");
    const int v = c.at("view").get<int>();
    ASSERT_GE(v, 0);
    ASSERT_LT(v, kViews);
    EXPECT_EQ(c.at("name"), cal.names[v]);
    const int feature = c.at("feature").get<int>();
    EXPECT_EQ(feature, c.at("row").get<int>() * target.cols + c.at("col").get<int>());
    // The file's view index is the calibration's order (sorted names), the render order is
    // the number in the name.
    const int rendered = std::stoi(cal.names[v].substr(4));
    const Eigen::Vector2d t = truth[rendered][feature];
    const Eigen::Vector2d raw(c.at("raw_px")[0].get<double>(), c.at("raw_px")[1].get<double>());
    ASSERT_FALSE(c.at("corrected_px").is_null());
    const Eigen::Vector2d corrected(c.at("corrected_px")[0].get<double>(),
                                    c.at("corrected_px")[1].get<double>());
    ss_raw += (raw - t).squaredNorm();
    ss_corrected += (corrected - t).squaredNorm();
    ++n;
  }
  const double raw_rms = std::sqrt(ss_raw / n), corrected_rms = std::sqrt(ss_corrected / n);
  std::cout << "centres vs truth: raw " << raw_rms << " px, corrected " << corrected_rms
            << " px over " << n << "\n";
  EXPECT_LT(corrected_rms, 0.5 * raw_rms);

  // The CSV carries the same rows: a header and one line per feature, same raw centres.
  std::istringstream csv(util::ReadTextFile(tmp / "centres.csv"));
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line.rfind("camera,view,name,row,col,feature,raw_x_px,raw_y_px,corrected_x_px", 0), 0u)
      << line;
  size_t rows = 0;
  while (std::getline(csv, line)) {
    std::vector<std::string> cells;
    std::stringstream ls(line);
    for (std::string cell; std::getline(ls, cell, ',');) cells.push_back(cell);
    ASSERT_EQ(cells.size(), 12u) << line;
    EXPECT_NEAR(std::stod(cells[6]), j["centres"][rows]["raw_px"][0].get<double>(), 1e-6);
    EXPECT_NEAR(std::stod(cells[9]), j["centres"][rows]["corrected_px"][1].get<double>(), 1e-6);
    ++rows;
  }
  EXPECT_EQ(rows, detected);
}

TEST(CalibrateFolder, CorruptOrMissingImagesGiveClearErrors) {
  const CalibrationTarget target = CalibrationTarget::Reference();
  test::TempDir tmp;
  EXPECT_THROW(CalibrateFolder(tmp / "missing", target), Error);
  // No images.
  try {
    CalibrateFolder(tmp.path(), target);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no images"), std::string::npos) << e.what();
  }
  // A corrupt image: the message names the file.
  {
    std::ofstream f(tmp / "view1.png");
    f << "not a png";
  }
  try {
    CalibrateFolder(tmp.path(), target);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("view1.png"), std::string::npos) << e.what();
  }
  // Stereo folders with unpaired images.
  std::filesystem::create_directories(tmp / "pair" / "left");
  std::filesystem::create_directories(tmp / "pair" / "right");
  std::ofstream(tmp / "pair" / "left" / "a.png") << "x";
  EXPECT_THROW(CalibrateFolder(tmp / "pair", target), Error);
}

}  // namespace
}  // namespace fringe::calib
