// Capture on a real GigE Vision protocol: Aravis' fake cameras on loopback addresses inside a
// private network namespace holding only loopback (test::EnterPrivateNetworkNamespace), Xvfb as the
// projector's screen. The cameras' images are made from what the X server shows when the frame is
// made, so a pattern shown in the wrong order, too late or not at all gives a wrong image here.
#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>
#include <thread>

#include "fringe/capture/capture.h"
#include "fringe/capture/projector.h"
#include "fringe/capture/sequence.h"
#include "fringe/cli/run_cli_for_test.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/io/json.h"
#include "fringe/phase/decode.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/phase/scheme_presets.h"
#include "fringe/scan/scan_folder.h"
#include "fringe/testing/capture_rig.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/util/files.h"

namespace fringe::capture {
namespace {

namespace fs = std::filesystem;
using test::FakeCamera;
using test::ResampleProjector;

// A small projector and small cameras keep every test fast; nothing depends on these sizes.
constexpr int kProjectorWidth = 256;
constexpr int kProjectorHeight = 160;
constexpr int kCameraWidth = 320;
constexpr int kCameraHeight = 200;

// Three frequencies, 4 steps, periods of 20, 24.6 and 29.1 projector pixels (16, 13 and 11
// fringes over 1.25 x the width; beats of 3 and 2 fringes, beat of beats 1).
phase::PatternScheme SmallScheme(int width = kProjectorWidth) {
  phase::SchemeParameters p;
  p.projector_width = width;
  p.projector_height = kProjectorHeight;
  p.counts = {16, 13, 11};
  return phase::SchemeFromArgument("heterodyne-4x3", p);
}

// The sensor of the simple tests: the left camera sees the projector image resampled, the right
// one the same mirrored (so the two can never be swapped unnoticed).
class Sensor {
 public:
  Sensor() {
    test::EnterPrivateNetworkNamespace();
    xvfb = std::make_unique<test::Xvfb>(kProjectorWidth, kProjectorHeight);
    left = MakeCamera("127.0.0.2", "FRINGE-L", false);
    right = MakeCamera("127.0.0.3", "FRINGE-R", true);
  }
  std::unique_ptr<FakeCamera> MakeCamera(const std::string& address, const std::string& serial,
                                         bool mirror) {
    auto c = std::make_unique<FakeCamera>(
        address, serial, xvfb->display(),
        [mirror](const cv::Mat& screen, double, double, int w, int h, int depth) {
          return ResampleProjector(screen, w, h, depth, mirror);
        });
    c->SetSize(kCameraWidth, kCameraHeight);
    return c;
  }
  CaptureOptions Options() const {
    CaptureOptions o;
    o.left = "127.0.0.2";
    o.right = "127.0.0.3";
    o.projector = xvfb->display();
    o.camera.exposure_us = 1000;
    o.settle_ms = 5;  // Xvfb shows a pattern once SDL presented it
    return o;
  }
  std::unique_ptr<test::Xvfb> xvfb;
  std::unique_ptr<FakeCamera> left, right;
};

// Every captured image of a view equals the pattern it was taken under, as each camera sees it.
void ExpectViewMatchesPatterns(const fs::path& view_dir, const phase::PatternScheme& scheme,
                               int bit_depth = 8) {
  const auto patterns = phase::GeneratePatterns(scheme, scheme.gamma_precompensation);
  const auto names = scheme.ImageNames();
  for (int c = 0; c < 2; ++c) {
    for (size_t k = 0; k < names.size(); ++k) {
      const fs::path file = view_dir / (c == 0 ? "left" : "right") / names[k];
      const cv::Mat image = io::ReadGrayImage(file);
      const cv::Mat expected =
          ResampleProjector(patterns[k], kCameraWidth, kCameraHeight, bit_depth, c == 1);
      ASSERT_EQ(image.size(), expected.size()) << file;
      ASSERT_EQ(image.type(), expected.type()) << file;
      EXPECT_EQ(cv::norm(image, expected, cv::NORM_INF), 0) << file << " is not pattern " << k;
    }
  }
}

TEST(Capture, OptionDefaultsPassCheck) {
  CaptureOptions o;
  o.left = "x";
  o.projector = ":0";
  EXPECT_NO_THROW(o.Check());
  EXPECT_NO_THROW(SequenceOptions().Check());
  EXPECT_NO_THROW(LatencyOptions().Check());
  EXPECT_NO_THROW(CameraSettings().Check());
  CameraSettings bad;
  bad.exposure_us = 0;
  EXPECT_NE(fringe::test::ErrorOf([&] { bad.Check(); }).find("exposure_us"), std::string::npos);
}

TEST(Capture, DevicesListsTheFakeCamerasAndTheScreen) {
  Sensor sensor;
  const DeviceList d = ListDevices(sensor.xvfb->display(), /*probe_opencv=*/false);
  std::vector<std::string> serials;
  for (const auto& c : d.cameras) {
    serials.push_back(c.serial);
    EXPECT_EQ(c.backend, "aravis");
    if (c.serial == "FRINGE-L") {
      EXPECT_EQ(c.width, kCameraWidth);
      EXPECT_EQ(c.height, kCameraHeight);
      EXPECT_EQ(c.pixel_format, "Mono8");
      EXPECT_NE(c.interface.find("127.0.0.2"), std::string::npos) << c.interface;
    }
  }
  EXPECT_NE(std::find(serials.begin(), serials.end(), "FRINGE-L"), serials.end());
  EXPECT_NE(std::find(serials.begin(), serials.end(), "FRINGE-R"), serials.end());
  ASSERT_EQ(d.screens.size(), 1u) << d.screens_error;
  EXPECT_EQ(d.screens[0].width, kProjectorWidth);
  EXPECT_EQ(d.screens[0].height, kProjectorHeight);
  const auto j = ToJson(d);
  EXPECT_EQ(j["cameras"].size(), d.cameras.size());
}

TEST(Capture, ViewsAreAppendedWithTheirImagesNumberingAndSettings) {
  Sensor sensor;
  fringe::test::TempDir tmp;
  const fs::path project = tmp / "scan";
  const auto scheme = SmallScheme();
  CaptureOptions o = sensor.Options();
  for (int v = 0; v < 3; ++v) {
    const CaptureSummary s = CaptureIntoProject(project, scheme, o);
    EXPECT_EQ(s.name, scan::IndexName(v));
    EXPECT_EQ(s.patterns, scheme.NumImages());
    ASSERT_EQ(s.feedback.size(), 2u);
    // The patterns fill the whole camera image: nearly every pixel decodes.
    EXPECT_GT(s.feedback[0].decodable_pct, 95.0);
    EXPECT_EQ(s.feedback[0].saturated_pct, 0.0);  // the test cameras never saturate
  }
  const scan::ScanFolder folder = scan::ScanFolder::Open(project);
  EXPECT_EQ(folder.manifest().views, 3);
  EXPECT_EQ(folder.manifest().generator, "fringe capture");
  EXPECT_EQ(folder.manifest().image_width, kCameraWidth);
  EXPECT_EQ(folder.manifest().image_height, kCameraHeight);
  EXPECT_EQ(folder.manifest().bit_depth, 8);
  EXPECT_EQ(phase::SchemeToJson(folder.ReadScheme()), phase::SchemeToJson(scheme));
  EXPECT_FALSE(fs::exists(project / ".capture-tmp"));
  for (const auto& view : folder.views()) {
    SCOPED_TRACE(view);
    ExpectViewMatchesPatterns(folder.layout().ViewDir(view), scheme);
    const auto settings = io::ReadJson(folder.layout().ViewDir(view) / "capture.json");
    ASSERT_EQ(settings["cameras"].size(), 2u);
    EXPECT_EQ(settings["cameras"][0]["serial"], "FRINGE-L");
    EXPECT_EQ(settings["cameras"][1]["serial"], "FRINGE-R");
    EXPECT_EQ(settings["camera_settings"]["exposure_us"], 1000.0);
    const auto& frames = settings["cameras"][0]["exposures"][0]["frames"];
    ASSERT_EQ(frames.size(), static_cast<size_t>(scheme.NumImages()));
    for (size_t k = 1; k < frames.size(); ++k) {
      // One trigger, one frame: frame ids and timestamps strictly increase.
      EXPECT_GT(frames[k]["frame_id"].get<uint64_t>(), frames[k - 1]["frame_id"].get<uint64_t>());
      EXPECT_GT(frames[k]["timestamp_ns"].get<uint64_t>(),
                frames[k - 1]["timestamp_ns"].get<uint64_t>());
      EXPECT_EQ(frames[k]["image"], scheme.ImageNames()[k]);
    }
  }
  // The decoded left stack gives the projector column each camera pixel sees.
  const auto stack = folder.ReadStack("001", scan::Camera::kLeft, scheme);
  const phase::DecodeResult d = phase::Decode(scheme, stack);
  int checked = 0;
  for (int y = 5; y < kCameraHeight; y += 37) {
    for (int x = 5; x < kCameraWidth; x += 41) {
      const float u = d.absolute_phase.at<float>(y, x);
      if (std::isnan(u)) continue;
      const int column = static_cast<int>((x + 0.5) * kProjectorWidth / kCameraWidth);
      EXPECT_NEAR(u, column, 1.0) << "pixel " << x << "," << y;
      ++checked;
    }
  }
  EXPECT_GT(checked, 30);
}

TEST(Capture, SixteenBitPixelFormatWritesSixteenBitImages) {
  Sensor sensor;
  fringe::test::TempDir tmp;
  const auto scheme = SmallScheme();
  CaptureOptions o = sensor.Options();
  o.camera.pixel_format = "Mono16";
  o.feedback = false;
  CaptureIntoProject(tmp / "scan", scheme, o);
  const scan::ScanFolder folder = scan::ScanFolder::Open(tmp / "scan");
  EXPECT_EQ(folder.manifest().bit_depth, 16);
  ExpectViewMatchesPatterns(folder.layout().ViewDir("000"), scheme, 16);
}

TEST(Capture, KilledCameraMidViewFailsCleanlyAndKeepsEarlierViews) {
  Sensor sensor;
  fringe::test::TempDir tmp;
  const fs::path project = tmp / "scan";
  const auto scheme = SmallScheme();
  CaptureOptions o = sensor.Options();
  o.sequence.grab_timeout_ms = 1000;
  CaptureIntoProject(project, scheme, o);
  CaptureIntoProject(project, scheme, o);
  const std::string manifest_before = util::ReadTextFile(project / "scan.json");
  // The right camera dies while the left one takes the 5th image of the third view.
  const int kill_at = sensor.left->frames() + 4;
  std::thread killer;
  sensor.left->on_frame = [&](int frame) {
    if (frame == kill_at) killer = std::thread([&] { sensor.right->Kill(); });
  };
  const std::string error = fringe::test::ErrorOf([&] { CaptureIntoProject(project, scheme, o); });
  if (killer.joinable()) killer.join();
  EXPECT_NE(error.find("127.0.0.3"), std::string::npos) << error;
  EXPECT_NE(error.find("pattern"), std::string::npos) << error;
  EXPECT_EQ(util::ReadTextFile(project / "scan.json"), manifest_before);
  EXPECT_FALSE(fs::exists(project / "views" / "002"));
  EXPECT_FALSE(fs::exists(project / ".capture-tmp"));
  const scan::ScanFolder folder = scan::ScanFolder::Open(project);
  EXPECT_EQ(folder.manifest().views, 2);
  ExpectViewMatchesPatterns(folder.layout().ViewDir("001"), scheme);
}

TEST(Capture, MissingCameraIsAnErrorAndWritesNothing) {
  Sensor sensor;
  fringe::test::TempDir tmp;
  CaptureOptions o = sensor.Options();
  o.right = "127.0.0.4";  // an address with no camera
  const std::string error =
      fringe::test::ErrorOf([&] { CaptureIntoProject(tmp / "scan", SmallScheme(), o); });
  EXPECT_NE(error.find("127.0.0.4"), std::string::npos) << error;
  EXPECT_FALSE(fs::exists(tmp / "scan"));
}

TEST(Capture, WrongScreenSizeOrMissingScreenIsRefused) {
  Sensor sensor;
  fringe::test::TempDir tmp;
  CaptureOptions o = sensor.Options();
  const auto wide = SmallScheme(kProjectorWidth + 64);
  std::string error = fringe::test::ErrorOf([&] { CaptureIntoProject(tmp / "scan", wide, o); });
  EXPECT_NE(error.find("pixel for pixel"), std::string::npos) << error;
  EXPECT_NE(error.find(util::StrCat(kProjectorWidth, "x", kProjectorHeight)), std::string::npos)
      << error;
  EXPECT_FALSE(fs::exists(tmp / "scan"));
  o.projector = ":4242";
  error = fringe::test::ErrorOf([&] { CaptureIntoProject(tmp / "scan", SmallScheme(), o); });
  EXPECT_NE(error.find(":4242"), std::string::npos) << error;
  EXPECT_FALSE(fs::exists(tmp / "scan"));
}

TEST(Capture, LostPacketsAreResentOrTheFrameRegrabbed) {
  Sensor sensor;
  fringe::test::TempDir tmp;
  const auto scheme = SmallScheme();
  CaptureOptions o = sensor.Options();
  o.feedback = false;
  // Each frame is about 45 GVSP packets: at 1 % loss a third of the frames lose one.
  sensor.left->SetLostPacketRatio(0.01);
  sensor.right->SetLostPacketRatio(0.01);
  // Aravis' fake camera does not answer resend requests: a frame with a lost packet stays
  // incomplete and the sequencer shows the pattern again (about one in three frames here).
  o.sequence.max_retries = 40;
  CaptureSummary s = CaptureIntoProject(tmp / "scan", scheme, o);
  EXPECT_GT(s.retries, 0);
  EXPECT_GT(s.frames_failed, 0u);
  EXPECT_GT(s.missing_packets, 0u);
  // Without resend requests the same.
  o.camera.packet_resend = false;
  s = CaptureIntoProject(tmp / "scan", scheme, o);
  EXPECT_GT(s.retries, 0);
  const scan::ScanFolder folder = scan::ScanFolder::Open(tmp / "scan");
  ASSERT_EQ(folder.manifest().views, 2);
  ExpectViewMatchesPatterns(folder.layout().ViewDir("000"), scheme);
  ExpectViewMatchesPatterns(folder.layout().ViewDir("001"), scheme);
  // The retries are bounded: with none allowed, the first incomplete frame (of 24, each lost
  // with probability ~1/3) ends the capture, naming the pattern, and no view is written.
  o.sequence.max_retries = 0;
  const std::string manifest_before = util::ReadTextFile(tmp / "scan" / "scan.json");
  const std::string error =
      fringe::test::ErrorOf([&] { CaptureIntoProject(tmp / "scan", scheme, o); });
  EXPECT_NE(error.find("no good frame after 1 tries"), std::string::npos) << error;
  EXPECT_NE(error.find("pattern"), std::string::npos) << error;
  EXPECT_EQ(util::ReadTextFile(tmp / "scan" / "scan.json"), manifest_before);
  EXPECT_FALSE(fs::exists(tmp / "scan" / "views" / "002"));
}

// The OpenCV (V4L2) backend without a webcam: what can be checked is how a camera is named and
// that a device that is not there is a clear error naming it (no V4L2 device, and no
// v4l2loopback, on the test machines; docs/capture.md).
TEST(Capture, OpenCvCameraSpecsAndAMissingDevice) {
  EXPECT_NE(fringe::test::ErrorOf([] { OpenCamera("opencv:x"); }).find("expected opencv:N"),
            std::string::npos);
  EXPECT_NE(fringe::test::ErrorOf([] { OpenCamera("/dev/video"); }).find("expected opencv:N"),
            std::string::npos);
  EXPECT_NE(fringe::test::ErrorOf([] { OpenCamera("opencv:256"); }).find("index"),
            std::string::npos);
  ASSERT_FALSE(fs::exists("/dev/video255"));
  const std::string error = fringe::test::ErrorOf([] { OpenCamera("/dev/video255"); });
  EXPECT_NE(error.find("/dev/video255"), std::string::npos) << error;
  EXPECT_NE(error.find("opencv:255"), std::string::npos) << error;
}

TEST(Capture, MeasuredLatencyMatchesTheInjectedOne) {
  Sensor sensor;
  fringe::test::TempDir tmp;
  // Each camera sees the screen as it was 40 ms (left) and 25 ms (right) earlier: the settle
  // time must cover the slower one.
  sensor.left->SetInjectedLatency(40);
  sensor.right->SetInjectedLatency(25);
  CaptureOptions o = sensor.Options();
  o.measure_latency = true;
  o.latency.max_latency_ms = 120;
  const CaptureSummary s = CaptureIntoProject(tmp / "scan", SmallScheme(), o);
  // The fake camera makes its frame up to 2 ms after the trigger (it polls at 500 Hz), and the
  // bisection stops at 1 ms: the measurement may be up to 3 ms early, 1 ms late, plus however
  // late the rig's own 40 ms are (its screen sampling at the changes of level, 1.5-2.5 ms
  // measured here; a measured 41.25 ms is the bisection's step after 40.31 ms).
  constexpr double kEarlyMs = 3.0, kLateMs = 1.0;
  const double rig_late_ms = sensor.left->MaxInjectedLatencyErrorMs();
  EXPECT_GE(s.latency_ms, 40 - kEarlyMs);
  EXPECT_LE(s.latency_ms, 40 + rig_late_ms + kLateMs) << "rig late by up to " << rig_late_ms;
  const auto stored = ReadProjectLatency(tmp / "scan");
  ASSERT_TRUE(stored.has_value());
  EXPECT_EQ(*stored, s.latency_ms);
  // The project exists (no views yet) and later captures use the measured settle time.
  EXPECT_EQ(scan::ScanFolder::Open(tmp / "scan").manifest().views, 0);
}

// --auto-exposure against cameras whose brightness grows with the exposure: camera pixel i of
// the part of the image that sees the projector gets 10 + level / 255 * exposure_us * rate_i DN
// (every pixel its own rate, so the saturated fraction grows smoothly), the last quarter of the
// columns sees only the ambient 10 DN (never lit). The exposure that saturates exactly 0.1 % of
// the lit pixels follows from the rates.
TEST(Capture, AutoExposureSaturatesAtMostATenthOfAPercentOfTheLitPixels) {
  test::EnterPrivateNetworkNamespace();
  test::Xvfb xvfb(kProjectorWidth, kProjectorHeight);
  constexpr double kAmbientDn = 10;
  // Rate of pixel (x, y) of the lit part, DN per us under white; the right camera is 1.25 x
  // brighter, so it decides.
  auto rate = [](int x, int y, double scale) {
    const double t = (static_cast<double>(y) * kCameraWidth + x) / (kCameraWidth * kCameraHeight);
    return scale * 0.008 * (1.0 + 0.5 * t);
  };
  const int lit_columns = kCameraWidth * 3 / 4;
  auto render = [&](double scale) {
    return [&, scale](const cv::Mat& screen, double exposure_us, double, int w, int h, int) {
      cv::Mat out(h, w, CV_8UC1);
      for (int y = 0; y < h; ++y) {
        const int py = std::min(screen.rows - 1, y * screen.rows / h);
        for (int x = 0; x < w; ++x) {
          const int px = std::min(screen.cols - 1, x * screen.cols / w);
          const double level = x < lit_columns ? screen.at<uint8_t>(py, px) / 255.0 : 0.0;
          out.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(
              std::floor(kAmbientDn + level * exposure_us * rate(x, y, scale)));
        }
      }
      return out;
    };
  };
  FakeCamera left("127.0.0.2", "FRINGE-L", xvfb.display(), render(1.0));
  FakeCamera right("127.0.0.3", "FRINGE-R", xvfb.display(), render(1.25));
  left.SetSize(kCameraWidth, kCameraHeight);
  right.SetSize(kCameraWidth, kCameraHeight);

  // The truth: at most floor(0.1 % of the lit pixels) may reach 255 DN, i.e. the exposure must
  // stay below 245 DN / the (allowed + 1)-th largest rate of the brighter camera.
  std::vector<double> rates;
  for (int y = 0; y < kCameraHeight; ++y) {
    for (int x = 0; x < lit_columns; ++x) rates.push_back(rate(x, y, 1.25));
  }
  std::sort(rates.rbegin(), rates.rend());
  const size_t allowed = static_cast<size_t>(0.001 * rates.size());
  const double limit_us = (255 - kAmbientDn) / rates[allowed];

  fringe::test::TempDir tmp;
  CaptureOptions o;
  o.left = "127.0.0.2";
  o.right = "127.0.0.3";
  o.projector = xvfb.display();
  o.settle_ms = 5;
  o.feedback = false;
  o.auto_exposure = true;
  o.auto_exposure_options.max_exposure_us = 100000;
  const CaptureSummary s = CaptureIntoProject(tmp / "scan", SmallScheme(), o);
  ASSERT_TRUE(s.auto_exposure.has_value());
  std::cerr << s.BriefReport() << "\n";
  // The bisection stops when its bracket is `resolution` wide: the longest good exposure is
  // within that of the limit, never above it.
  const double resolution = o.auto_exposure_options.resolution;
  EXPECT_LT(s.auto_exposure->exposure_us, limit_us);
  EXPECT_GE(s.auto_exposure->exposure_us, limit_us / (1 + resolution));
  ASSERT_EQ(s.auto_exposure->chosen.saturated_fraction.size(), 2u);
  EXPECT_LE(s.auto_exposure->chosen.saturated_fraction[1], 0.001);
  // Only the part that sees the projector is lit.
  EXPECT_NEAR(s.auto_exposure->chosen.lit_fraction[0], 0.75, 1e-9);
  // The view was captured at that exposure, and says so.
  EXPECT_EQ(s.exposure_us, s.auto_exposure->exposure_us);
  const auto settings = io::ReadJson(tmp / "scan" / "views" / "000" / "capture.json");
  EXPECT_EQ(settings["camera_settings"]["exposure_us"].get<double>(), s.exposure_us);
  EXPECT_EQ(settings["auto_exposure"]["exposure_us"].get<double>(), s.exposure_us);
  const cv::Mat white_seen = io::ReadGrayImage(tmp / "scan" / "views" / "000" / "right" /
                                               SmallScheme().ImageNames().front());
  double max_dn = 0;
  cv::minMaxLoc(white_seen, nullptr, &max_dn);
  EXPECT_LT(max_dn, 255);  // the fringe images stay below saturation
}

TEST(Capture, BoardPosesGoToTheCalibrationFolder) {
  Sensor sensor;
  fringe::test::TempDir tmp;
  const auto scheme = SmallScheme();
  CaptureOptions o = sensor.Options();
  o.board = true;
  EXPECT_NE(
      fringe::test::ErrorOf([&] { CaptureIntoProject(tmp / "scan", scheme, o); }).find("--target"),
      std::string::npos);
  const fs::path target = tmp / "target.json";
  io::WriteJson(target, io::TargetToJson(CalibrationTarget::Reference()));
  o.target_file = target;
  CaptureIntoProject(tmp / "scan", scheme, o);
  CaptureIntoProject(tmp / "scan", scheme, o);
  const scan::ScanFolder folder = scan::ScanFolder::Open(tmp / "scan");
  EXPECT_EQ(folder.manifest().calibration_images, 2);
  EXPECT_EQ(folder.calibration_images(), (std::vector<std::string>{"000.png", "001.png"}));
  const cv::Mat white =
      io::ReadGrayImage(folder.layout().CalibrationDir(scan::Camera::kRight) / "001.png");
  EXPECT_EQ(cv::countNonZero(white != 16 + 3 * 255 / 4), 0);  // the white frame, as seen
}

TEST(Capture, CliDevicesAndCaptureExitCodes) {
  Sensor sensor;
  fringe::test::TempDir tmp;
  std::string out, err;
  ASSERT_EQ(cli::RunCli({"devices", "--json", "--no-opencv", "--display", sensor.xvfb->display()},
                        &out, &err),
            0)
      << err;
  const auto devices = nlohmann::json::parse(out);
  EXPECT_GE(devices["cameras"].size(), 2u);
  EXPECT_EQ(devices["screens"].size(), 1u);
  const std::string project = (tmp / "scan").string();
  const std::vector<std::string> common = {
      "capture",     project,     "--left",      "FRINGE-L",
      "--right",     "127.0.0.3", "--projector", sensor.xvfb->display(),
      "--settle-ms", "5",         "--counts",    "16,13,11"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = common;
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  ASSERT_EQ(cli::RunCli(with({"--width", std::to_string(kProjectorWidth), "--height",
                              std::to_string(kProjectorHeight), "--json"}),
                        &out, &err),
            0)
      << err;
  const auto summary = nlohmann::json::parse(out);
  EXPECT_EQ(summary["name"], "000");
  EXPECT_EQ(summary["feedback"].size(), 2u);
  // Without a rig there is no 3D feedback, and the summary says why.
  EXPECT_TRUE(summary["view_feedback"].is_null());
  EXPECT_NE(summary["view_feedback_message"].get<std::string>().find("no rig"), std::string::npos);
  // The projector screen is 256 px wide, the scheme 1280 (the preset's default width).
  EXPECT_EQ(cli::RunCli(with({"--scheme", "heterodyne-4x3"}), &out, &err), 1);
  EXPECT_NE(err.find("fringe: error:"), std::string::npos) << err;
  // A usage error: no --left.
  EXPECT_EQ(cli::RunCli({"capture", project, "--projector", sensor.xvfb->display()}, &out, &err),
            2);
  EXPECT_EQ(scan::ScanFolder::Open(tmp / "scan").manifest().views, 1);
}

}  // namespace
}  // namespace fringe::capture
