// Closed loop: fringe capture drives Aravis' fake GigE Vision cameras and an Xvfb projector
// screen; each fake camera renders, with the simulator, the demo part lit by whatever pattern
// the projector window shows at that moment (read back from the X server). Then the whole
// scanner (pipeline::RunScan, `fringe scan`) runs on the captured folder and must reproduce the
// simulator's truth as well as it does on the same scan simulated directly (sim::SimulateScan):
// pattern order, sync and file layout are right end to end.
#include <gtest/gtest.h>

#include <array>
#include <filesystem>
#include <map>
#include <mutex>

#include "fringe/capture/capture.h"
#include "fringe/capture/test_rig.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/io/json.h"
#include "fringe/pipeline/scan.h"
#include "fringe/scan/scan_folder.h"
#include "fringe/sim/board.h"
#include "fringe/sim/scan.h"
#include "fringe_test.h"

namespace fringe::capture {
namespace {

namespace fs = std::filesystem;

// What the simulated sensor sees at its current pose: the simulator's rendering of the scene
// under each projector image, found by the image the projector window shows (read back from
// the X server). Rendering a 640 x 512 frame takes longer than GigE Vision's heartbeat allows
// the fake camera's thread to be busy, so the renderings of a pose are made before its capture
// (a cache keyed by the projector image; what the camera returns is decided by the screen).
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
  sim::SimulateScan(rig, so, tmp / "simulated");
  const sim::ScanSimulator simulator(rig, so);

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
  o.sequence.grab_timeout_ms = 10000;  // rendering a frame takes a while on a loaded machine
  const fs::path project = tmp / "captured";
  for (int v = 0; v < so.views; ++v) {
    const sim::ViewImages images = simulator.RenderView(v);
    std::vector<std::array<cv::Mat, 2>> cams;
    for (size_t k = 0; k < images.left.images.size(); ++k) {
      cams.push_back({images.left.images[k], images.right.images[k]});
    }
    stage.Set(simulator.patterns(), cams);
    const CaptureSummary s = CaptureIntoProject(project, simulator.scheme(), o);
    ASSERT_EQ(s.name, scan::IndexName(v));
    EXPECT_GT(s.feedback[0].decodable_pct, 20.0) << "view " << v;
  }
  const fs::path target = tmp / "target.json";
  io::WriteJson(target, io::TargetToJson(so.target));
  o.board = true;
  o.target_file = target;
  for (int b = 0; b < so.calibration_images; ++b) {
    // The board is photographed under the white frame.
    const sim::StereoBoardImages board = simulator.RenderBoard(b);
    stage.Set({cv::Mat(rig.projector->height, rig.projector->width, CV_8UC1, cv::Scalar(255))},
              {{board.left.image, board.right.image}});
    CaptureIntoProject(project, simulator.scheme(), o);
  }

  // Every captured image is the simulated scan's image of the same name: order, sync and layout.
  const scan::ScanFolder captured_folder = scan::ScanFolder::Open(project);
  const scan::ScanFolder simulated_folder = scan::ScanFolder::Open(tmp / "simulated");
  ASSERT_EQ(captured_folder.views(), simulated_folder.views());
  for (const auto& view : captured_folder.views()) {
    for (scan::Camera c : {scan::Camera::kLeft, scan::Camera::kRight}) {
      const auto a = captured_folder.ReadStack(view, c, simulator.scheme());
      const auto b = simulated_folder.ReadStack(view, c, simulator.scheme());
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

  pipeline::ScanOptions scan_options;
  scan_options.write_report = false;  // the figures are in the summary
  const pipeline::ScanSummary captured =
      pipeline::RunScan(project, tmp / "out-captured", scan_options);
  const pipeline::ScanSummary simulated =
      pipeline::RunScan(tmp / "simulated", tmp / "out-sim", scan_options);
  ASSERT_EQ(captured.status, pipeline::ScanStatus::kOk) << captured.message;
  ASSERT_EQ(simulated.status, pipeline::ScanStatus::kOk) << simulated.message;
  std::cerr << "captured: fused_rms_mm " << captured.fused_rms_mm << " pose_rot_err_deg "
            << captured.pose_rot_err_deg << " pose_trans_err_mm " << captured.pose_trans_err_mm
            << "\nsimulated: fused_rms_mm " << simulated.fused_rms_mm << " pose_rot_err_deg "
            << simulated.pose_rot_err_deg << " pose_trans_err_mm " << simulated.pose_trans_err_mm
            << "\n";
  // The same images give the same measurement: the scanner's figures against the truth agree
  // (the scanner is deterministic; the tolerances only absorb the last digits).
  constexpr double kRmsTolMm = 1e-6, kRotTolDeg = 1e-6, kTransTolMm = 1e-5;
  EXPECT_EQ(captured.views_ok, so.views);
  EXPECT_NEAR(captured.fused_rms_mm, simulated.fused_rms_mm, kRmsTolMm);
  EXPECT_NEAR(captured.pose_rot_err_deg, simulated.pose_rot_err_deg, kRotTolDeg);
  EXPECT_NEAR(captured.pose_trans_err_mm, simulated.pose_trans_err_mm, kTransTolMm);
  // And they are those of a good scan of the half-size rig (this scan: fused RMS 0.026 mm, pose
  // errors 0.0077 deg / 0.042 mm).
  EXPECT_LT(captured.fused_rms_mm, 0.06);
  EXPECT_LT(captured.pose_rot_err_deg, 0.05);
  EXPECT_LT(captured.pose_trans_err_mm, 0.2);
}

}  // namespace
}  // namespace fringe::capture
