// Closed loop: fringe capture drives Aravis' fake GigE Vision cameras and an Xvfb projector
// screen; each fake camera renders, with the simulator, the demo part lit by whatever pattern
// the projector window shows at that moment (read back from the X server). Then the whole
// scanner (pipeline::RunScan, `fringe scan`) runs on the captured folder and must reproduce the
// simulator's truth as well as it does on the same scan simulated directly (sim::SimulateScan):
// pattern order, sync and file layout are right end to end. On the way, each view's 3D
// feedback (markers seen, registration to the previous views, overlap; feedback.h) is checked.
#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <map>
#include <mutex>

#include "fringe/calib/projector_folder.h"
#include "fringe/capture/capture.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/io/json.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/pipeline/scan.h"
#include "fringe/scan/scan_folder.h"
#include "fringe/sim/projector_board.h"
#include "fringe/sim/scan.h"
#include "fringe/testing/capture_rig.h"
#include "fringe/testing/fringe_test.h"

namespace fringe::capture {
namespace {

namespace fs = std::filesystem;

// What the simulated sensor sees at its current pose: the simulator's rendering of the scene
// under each projector image, found by the image the projector window shows (read back from
// the X server). Rendering a 640 x 512 frame takes longer than GigE Vision's heartbeat allows
// the fake camera's thread to be busy, so the renderings of a pose are made before its capture
// (the simulated scan's images, rendered once; a table keyed by the projector image: what the
// camera returns is decided by the screen).
struct Stage {
  std::mutex mutex;
  std::map<std::string, std::array<cv::Mat, 2>> seen;  // projector image bytes -> left, right

  static std::string Key(const cv::Mat& projector) {
    const cv::Mat c = projector.isContinuous() ? projector : projector.clone();
    return std::string(reinterpret_cast<const char*>(c.data), c.total());
  }
  void Set(const std::vector<cv::Mat>& projector, const std::vector<std::array<cv::Mat, 2>>& cams) {
    std::lock_guard<std::mutex> lock(mutex);
    seen.clear();
    for (size_t k = 0; k < projector.size(); ++k) seen[Key(projector[k])] = cams[k];
  }
  // The camera's image under `screen`; an image the sensor was not prepared for (the black
  // frame shown when the window opens) is dark.
  cv::Mat Look(const cv::Mat& screen, int camera, int w, int h) {
    std::lock_guard<std::mutex> lock(mutex);
    const auto it = seen.find(Key(screen));
    if (it == seen.end()) return cv::Mat::zeros(h, w, CV_8UC1);
    return it->second[camera];
  }
};

TEST(ClosedLoop, CapturedScanReproducesTheSimulatorsTruth) {
  test::EnterPrivateNetworkNamespace();
  // The half-size rig (markers need it), 4 views of the demo part, 8 board poses.
  const StereoRig rig = sim::ScaledRig(StereoRig::Reference(), 0.5);
  sim::ScanOptions so;
  so.scene = "demo";
  so.views = 4;
  so.seed = 3;
  so.calibration_images = 8;
  so.truth_maps = false;
  so.scheme = phase::MakeScheme("heterodyne-4x3", rig.projector->width, rig.projector->height);
  so.scheme->gamma_precompensation = so.render.projector.gamma;
  fringe::test::TempDir tmp;
  const auto t_start = std::chrono::steady_clock::now();
  sim::SimulateScan(rig, so, tmp / "simulated");
  const scan::ScanFolder simulated_folder = scan::ScanFolder::Open(tmp / "simulated");
  const phase::PatternScheme scheme = simulated_folder.ReadScheme();
  // The projector images exactly as fringe capture shows them.
  const std::vector<cv::Mat> patterns =
      phase::GeneratePatterns(scheme, scheme.gamma_precompensation);
  const auto t_simulated = std::chrono::steady_clock::now();

  test::Xvfb xvfb(rig.projector->width, rig.projector->height);
  Stage stage;
  auto render = [&](int camera) {
    return [&stage, camera](const cv::Mat& screen, double, double, int w, int h, int) {
      return stage.Look(screen, camera, w, h);
    };
  };
  test::FakeCamera left("127.0.0.2", "SIM-L", xvfb.display(), render(0));
  test::FakeCamera right("127.0.0.3", "SIM-R", xvfb.display(), render(1));
  left.SetSize(rig.left.width, rig.left.height);
  right.SetSize(rig.right.width, rig.right.height);

  CaptureOptions o;
  o.left = "SIM-L";
  o.right = "SIM-R";
  o.projector = xvfb.display();
  o.settle_ms = 5;
  o.sequence.grab_timeout_ms = 10000;  // a loaded machine
  // The 3D feedback with the true rig: markers seen and registration to the previous views.
  o.rig_file = simulated_folder.layout().TruthRig();
  const fs::path project = tmp / "captured";
  for (int v = 0; v < so.views; ++v) {
    // What each camera sees under each pattern at this pose: the simulator's images of the
    // simulated scan (rendered once, by SimulateScan; the fake cameras hand them out according
    // to the pattern on the screen).
    const std::string view = scan::IndexName(v);
    const auto l = simulated_folder.ReadStack(view, scan::Camera::kLeft, scheme);
    const auto r = simulated_folder.ReadStack(view, scan::Camera::kRight, scheme);
    std::vector<std::array<cv::Mat, 2>> cams;
    for (size_t k = 0; k < l.size(); ++k) cams.push_back({l[k], r[k]});
    stage.Set(patterns, cams);
    const CaptureSummary s = CaptureIntoProject(project, scheme, o);
    ASSERT_EQ(s.name, view);
    EXPECT_GT(s.feedback[0].decodable_pct, 20.0) << "view " << v;
    // The demo part carries sticky markers that every view sees; from the second view on, the
    // new view registers to the previous ones by them and overlaps them.
    ASSERT_TRUE(s.view.has_value()) << s.view_message;
    EXPECT_TRUE(s.view->reconstructed) << s.view->message;
    EXPECT_GT(s.view->points, 10000) << "view " << v;
    EXPECT_GE(s.view->markers, 3) << "view " << v;
    EXPECT_EQ(s.view->previous_views, v);
    EXPECT_EQ(s.view->registration_run, v > 0);
    if (v > 0) {
      EXPECT_TRUE(s.view->registered) << "view " << v << ": " << s.view->registration_message;
      EXPECT_EQ(s.view->registration_path, "markers") << "view " << v;
      EXPECT_GE(s.view->matched_markers, 3) << "view " << v;
      EXPECT_GT(s.view->overlap_fraction, 0.1) << "view " << v;
      EXPECT_LE(s.view->overlap_fraction, 1.0) << "view " << v;
    }
    std::cerr << s.BriefReport() << " (3D feedback " << s.view->seconds << " s)\n";
  }
  const fs::path target = tmp / "target.json";
  io::WriteJson(target, io::TargetToJson(so.target));
  o.board = true;
  o.target_file = target;
  const cv::Mat white(rig.projector->height, rig.projector->width, CV_8UC1, cv::Scalar(255));
  for (const std::string& name : simulated_folder.calibration_images()) {
    // The board is photographed under the white frame.
    stage.Set(
        {white},
        {{io::ReadGrayImage(simulated_folder.layout().CalibrationDir(scan::Camera::kLeft) / name),
          io::ReadGrayImage(simulated_folder.layout().CalibrationDir(scan::Camera::kRight) /
                            name)}});
    CaptureIntoProject(project, scheme, o);
  }
  const auto t_captured = std::chrono::steady_clock::now();

  // Every captured image is the simulated scan's image of the same name: order, sync and layout.
  const scan::ScanFolder captured_folder = scan::ScanFolder::Open(project);
  ASSERT_EQ(captured_folder.views(), simulated_folder.views());
  for (const auto& view : captured_folder.views()) {
    for (scan::Camera c : {scan::Camera::kLeft, scan::Camera::kRight}) {
      const auto a = captured_folder.ReadStack(view, c, scheme);
      const auto b = simulated_folder.ReadStack(view, c, scheme);
      for (size_t k = 0; k < a.size(); ++k) {
        ASSERT_EQ(cv::norm(a[k], b[k], cv::NORM_INF), 0)
            << "view " << view << " " << scan::CameraName(c) << " image " << k;
      }
    }
  }
  ASSERT_EQ(captured_folder.calibration_images(), simulated_folder.calibration_images());
  for (const auto& name : captured_folder.calibration_images()) {
    for (scan::Camera c : {scan::Camera::kLeft, scan::Camera::kRight}) {
      const cv::Mat a = io::ReadGrayImage(captured_folder.layout().CalibrationDir(c) / name);
      const cv::Mat b = io::ReadGrayImage(simulated_folder.layout().CalibrationDir(c) / name);
      ASSERT_EQ(cv::norm(a, b, cv::NORM_INF), 0) << "board " << name << " " << scan::CameraName(c);
    }
  }

  // The simulator's truth for the captured folder: the same poses, scene and rig.
  fs::copy(tmp / "simulated" / "truth", project / "truth", fs::copy_options::recursive);
  scan::ScanManifest manifest = scan::ScanFolder::Open(project).manifest();
  manifest.truth = "truth";
  scan::WriteManifest(project / "scan.json", manifest);

  // The scanner reads the images (equal, above) and the manifest, scheme and target: equal
  // where the scanner looks, so `fringe scan` of the captured folder is the simulated scan's
  // measurement (a second scan of the simulated folder gave the same figures to the last digit;
  // it proves nothing more and doubled the test's time).
  const scan::ScanManifest& cm = captured_folder.manifest();
  const scan::ScanManifest& sm = simulated_folder.manifest();
  EXPECT_EQ(cm.image_width, sm.image_width);
  EXPECT_EQ(cm.image_height, sm.image_height);
  EXPECT_EQ(cm.bit_depth, sm.bit_depth);
  EXPECT_EQ(cm.cameras, sm.cameras);
  EXPECT_EQ(cm.views, sm.views);
  EXPECT_EQ(cm.calibration_images, sm.calibration_images);
  EXPECT_EQ(phase::SchemeToJson(captured_folder.ReadScheme()), phase::SchemeToJson(scheme));
  EXPECT_EQ(io::TargetToJson(captured_folder.ReadTarget()),
            io::TargetToJson(simulated_folder.ReadTarget()));

  pipeline::ScanOptions scan_options;
  scan_options.write_report = false;  // the figures are in the summary
  const pipeline::ScanSummary captured =
      pipeline::RunScan(project, tmp / "out-captured", scan_options);
  ASSERT_EQ(captured.status, pipeline::ScanStatus::kOk) << captured.message;
  const auto t_scanned = std::chrono::steady_clock::now();
  auto s_between = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
  std::cerr << "simulate " << s_between(t_start, t_simulated) << " s, capture (with the 3D "
            << "feedback) " << s_between(t_simulated, t_captured) << " s, scan "
            << s_between(t_captured, t_scanned) << " s\n";
  std::cerr << "captured: fused_rms_mm " << captured.fused_rms_mm << " pose_rot_err_deg "
            << captured.pose_rot_err_deg << " pose_trans_err_mm " << captured.pose_trans_err_mm
            << "\n";
  // The figures of the simulated scan of this part with this rig (fused RMS 0.0263 mm, pose
  // errors 0.0077 deg / 0.042 mm, the same to the last digit with the captured folder), with
  // room for another machine's renderer: a wrong pattern order, image or layout breaks them by
  // far more.
  EXPECT_EQ(captured.views_ok, so.views);
  EXPECT_LT(captured.fused_rms_mm, 0.06);
  EXPECT_LT(captured.pose_rot_err_deg, 0.05);
  EXPECT_LT(captured.pose_trans_err_mm, 0.2);
}

// One camera + projector: `fringe capture --board` with one camera takes each board pose under
// a white frame and under the fringes of both directions, into the pose folders that
// `fringe calibrate` reads; the fake camera returns the simulator's images of the board at that
// pose under whatever the screen shows. The captured poses are the simulated folder's images
// under the same names, and they calibrate the projector to the truth (the bounds of
// calib/projector_test.cc for this rig, 6 poses).
TEST(ClosedLoop, OneCameraBoardPosesCalibrateTheProjector) {
  test::EnterPrivateNetworkNamespace();
  constexpr double kMaxFocalErrPct = 0.03;
  constexpr double kMaxPrincipalErrPx = 0.3;
  constexpr double kMaxTranslationErrMm = 0.1;
  constexpr double kMaxRotationErrDeg = 0.015;
  const StereoRig rig = sim::ScaledRig(StereoRig::Reference(), 0.5);
  const CalibrationTarget target = CalibrationTarget::Reference();
  fringe::test::TempDir tmp;
  sim::ProjectorCalibrationFolderOptions so;
  so.poses.count = 6;
  so.poses.seed = 5;
  so.fringes.supersampling = 1;  // as calib/projector_test.cc's two-camera test
  sim::WriteProjectorCalibrationFolder(rig, target, tmp / "simulated", so);
  const auto schemes = sim::BothDirectionSchemes(*rig.projector);

  test::Xvfb xvfb(rig.projector->width, rig.projector->height);
  Stage stage;
  test::FakeCamera camera("127.0.0.2", "SIM-C", xvfb.display(),
                          [&stage](const cv::Mat& screen, double, double, int w, int h, int) {
                            return stage.Look(screen, 0, w, h);
                          });
  camera.SetSize(rig.left.width, rig.left.height);
  CaptureOptions o;
  o.left = "SIM-C";
  o.projector = xvfb.display();
  o.settle_ms = 5;
  o.sequence.grab_timeout_ms = 10000;  // a loaded machine
  o.board = true;
  o.target_file = tmp / "simulated" / "target.json";
  o.horizontal_scheme = schemes[1];  // the simulator's horizontal scheme
  const fs::path project = tmp / "captured";
  std::vector<cv::Mat> shown = {
      cv::Mat(rig.projector->height, rig.projector->width, CV_8UC1, cv::Scalar(255))};
  std::vector<std::string> names = {"board.png"};
  for (const auto& s : schemes) {
    for (const cv::Mat& p : phase::GeneratePatterns(s, s.gamma_precompensation)) shown.push_back(p);
    for (const auto& n : s.ImageNames())
      names.push_back(phase::DirectionName(s.direction) + "/" + n);
  }
  for (int k = 0; k < so.poses.count; ++k) {
    const fs::path pose = tmp / "simulated" / scan::IndexName(k);
    std::vector<std::array<cv::Mat, 2>> seen;
    for (const auto& n : names) seen.push_back({io::ReadGrayImage(pose / n), cv::Mat()});
    stage.Set(shown, seen);
    const CaptureSummary s = CaptureIntoProject(project, schemes[0], o);
    EXPECT_EQ(s.kind, "board");
    EXPECT_EQ(s.name, scan::IndexName(k));
    EXPECT_EQ(s.patterns, static_cast<int>(names.size()));
  }
  // The layout and every image: the simulated folder's.
  const scan::ScanFolder folder = scan::ScanFolder::Open(project);
  EXPECT_EQ(folder.manifest().cameras, 1);
  EXPECT_EQ(folder.manifest().calibration_images, so.poses.count);
  for (int k = 0; k < so.poses.count; ++k) {
    const std::string pose = scan::IndexName(k);
    for (const auto& n : names) {
      const cv::Mat a = io::ReadGrayImage(project / "calibration" / pose / n);
      const cv::Mat b = io::ReadGrayImage(tmp / "simulated" / pose / n);
      ASSERT_EQ(cv::norm(a, b, cv::NORM_INF), 0) << "pose " << pose << " " << n;
    }
    for (const auto& s : schemes) {
      const fs::path m =
          project / "calibration" / pose / phase::DirectionName(s.direction) / "manifest.json";
      EXPECT_EQ(phase::SchemeToJson(phase::ReadScheme(m)), phase::SchemeToJson(s)) << m;
    }
  }
  // `fringe calibrate` of the captured poses: the camera + projector calibration recovers the
  // true projector.
  calib::ProjectorFolderOptions fo;
  fo.features.window_radius_px = 10;  // half resolution
  const calib::ProjectorFolderCalibration cal =
      calib::CalibrateProjectorFolder(project / "calibration", target, fo);
  ASSERT_EQ(cal.layout, calib::ProjectorFolderLayout::kCameraProjector);
  ASSERT_TRUE(cal.ok()) << cal.message();
  const CameraModel& p = *cal.rig.projector;
  const double focal_err_pct = 100 * std::abs(p.fx - rig.projector->fx) / rig.projector->fx;
  const double principal_err_px = std::hypot(p.cx - rig.projector->cx, p.cy - rig.projector->cy);
  const Rigid3d d = cal.rig.projector_from_left * rig.projector_from_left.Inverse();
  const double rotation_deg = Eigen::AngleAxisd(d.rotation()).angle() * 180 / M_PI;
  const double translation_mm =
      (cal.rig.projector_from_left.translation() - rig.projector_from_left.translation()).norm();
  std::cerr << cal.BriefReport() << "\nfocal error " << focal_err_pct << " %, principal point "
            << principal_err_px << " px, rotation " << rotation_deg << " deg, translation "
            << translation_mm << " mm\n";
  EXPECT_LT(focal_err_pct, kMaxFocalErrPct);
  EXPECT_LT(principal_err_px, kMaxPrincipalErrPx);
  EXPECT_LT(rotation_deg, kMaxRotationErrDeg);
  EXPECT_LT(translation_mm, kMaxTranslationErrMm);
}

}  // namespace
}  // namespace fringe::capture
