// `fringe capture --preview` on the fake GigE Vision cameras (private network namespace, Xvfb as
// the projector's screen and a second Xvfb as the operator's): the figures it prints are checked
// against what the fake cameras are built to see — a known lit area, a known saturated band, and
// one camera that sees the projector blurred — and PROJECT is never written.
#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>
#include <opencv2/imgproc.hpp>

#include "fringe/capture/preview.h"
#include "fringe/cli/run_cli_for_test.h"
#include "fringe/testing/capture_rig.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"

namespace fringe::capture {
namespace {

namespace fs = std::filesystem;
using test::FakeCamera;

constexpr int kProjectorWidth = 256;
constexpr int kProjectorHeight = 160;
constexpr int kCameraWidth = 320;
constexpr int kCameraHeight = 200;
constexpr int kBandRows = kCameraHeight / 4;  // the left camera's over-bright band

// Camera pixel (x, y) sees projector pixel ((x + 0.5) pw / w, (y + 0.5) ph / h) with the response
// 16 + 3 v / 4, but only in the columns [lit_begin, lit_end) (elsewhere nothing of the projector:
// 16 DN). `band` adds 100 DN to the top quarter, so white saturates there (16 + 191 + 100 > 255)
// and only there. `blur` blurs the projector image (sigma 2 projector px) before it is seen: an
// out-of-focus lens. The blur is applied in projector space, so a uniform white stays uniform
// and the lit area stays exactly the columns given.
test::Render MakeRender(int lit_begin, int lit_end, bool band, bool blur) {
  return [=](const cv::Mat& screen, double, double, int w, int h, int) {
    cv::Mat seen = screen;
    if (blur) cv::GaussianBlur(screen, seen, cv::Size(0, 0), 2.0, 2.0, cv::BORDER_REFLECT);
    cv::Mat out(h, w, CV_8UC1);
    for (int y = 0; y < h; ++y) {
      const int py = static_cast<int>((y + 0.5) * seen.rows / h);
      for (int x = 0; x < w; ++x) {
        const int px = static_cast<int>((x + 0.5) * seen.cols / w);
        double v = 16;
        if (x >= lit_begin && x < lit_end) v += 0.75 * seen.at<uint8_t>(py, px);
        if (band && y < kBandRows) v += 100;
        out.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(v);
      }
    }
    return out;
  };
}

TEST(CapturePreview, FiguresMatchWhatTheCamerasSeeAndNothingIsWritten) {
  test::EnterPrivateNetworkNamespace();
  test::Xvfb projector(kProjectorWidth, kProjectorHeight);
  test::Xvfb operator_screen(800, 600);
  // Left: sharp, lit in the left half, saturated band. Right: blurred, lit in the right three
  // quarters, never saturated. The right camera's larger lit area and its unclipped contrast
  // would both raise its focus measure: only the blur can make it lower than the left's.
  FakeCamera left("127.0.0.2", "FRINGE-L", projector.display(),
                  MakeRender(0, kCameraWidth / 2, true, false));
  FakeCamera right("127.0.0.3", "FRINGE-R", projector.display(),
                   MakeRender(kCameraWidth / 4, kCameraWidth, false, true));
  left.SetSize(kCameraWidth, kCameraHeight);
  right.SetSize(kCameraWidth, kCameraHeight);

  fringe::test::TempDir tmp;
  const std::string project = (tmp / "scan").string();
  auto run = [&](const std::string& pattern, const std::string& left_spec, std::string* out,
                 std::string* err) {
    return cli::RunCli({"capture",
                        project,
                        "--left",
                        left_spec,
                        "--right",
                        "127.0.0.3",
                        "--projector",
                        projector.display(),
                        "--width",
                        std::to_string(kProjectorWidth),
                        "--height",
                        std::to_string(kProjectorHeight),
                        "--counts",
                        "16,13,11",
                        "--settle-ms",
                        "5",
                        "--exposure-us",
                        "1000",
                        "--preview",
                        "--preview-screen",
                        operator_screen.display(),
                        "--preview-pattern",
                        pattern,
                        "--preview-frames",
                        "3",
                        "--json"},
                       out, err);
  };
  std::string out, err;
  ASSERT_EQ(run("white", "127.0.0.2", &out, &err), 0) << err;
  auto j = nlohmann::json::parse(out)["preview"];
  EXPECT_EQ(j["refreshes"], 3);
  EXPECT_EQ(j["pattern"], "white");
  ASSERT_EQ(j["cameras"].size(), 2u);
  const auto& l = j["cameras"][0];
  const auto& r = j["cameras"][1];
  EXPECT_EQ(l["camera"], "left");
  EXPECT_EQ(r["camera"], "right");
  // Lit: exactly the columns that see the projector.
  EXPECT_DOUBLE_EQ(l["lit_fraction"].get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(r["lit_fraction"].get<double>(), 0.75);
  // Saturated under white: the band's lit part, 50 rows x 160 columns = 12.5 % of the image and
  // a quarter of the lit pixels; the right camera none.
  EXPECT_DOUBLE_EQ(l["saturated_pct"].get<double>(), 12.5);
  EXPECT_DOUBLE_EQ(l["saturated_lit_pct"].get<double>(), 25.0);
  EXPECT_DOUBLE_EQ(r["saturated_pct"].get<double>(), 0.0);
  EXPECT_DOUBLE_EQ(r["saturated_lit_pct"].get<double>(), 0.0);

  // Under the focus pattern the sharp camera has the higher focus measure, by far (sigma 2 px
  // keeps under a third of the checkerboard's fundamental and much less of its edges); the lit
  // area is still measured under a white frame.
  ASSERT_EQ(run("focus", "127.0.0.2", &out, &err), 0) << err;
  j = nlohmann::json::parse(out)["preview"];
  EXPECT_EQ(j["pattern"], "focus");
  const double sharp = j["cameras"][0]["focus"].get<double>();
  const double blurred = j["cameras"][1]["focus"].get<double>();
  std::cerr << "focus measure: sharp " << sharp << ", blurred " << blurred << "\n";
  EXPECT_GT(sharp, 5 * blurred);
  EXPECT_GT(blurred, 0);
  EXPECT_DOUBLE_EQ(j["cameras"][0]["lit_fraction"].get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(j["cameras"][1]["lit_fraction"].get<double>(), 0.75);
  // The crosshair too: the lit area is measured under white whatever the projector shows.
  ASSERT_EQ(run("crosshair", "127.0.0.2", &out, &err), 0) << err;
  j = nlohmann::json::parse(out)["preview"];
  EXPECT_EQ(j["pattern"], "crosshair");
  EXPECT_DOUBLE_EQ(j["cameras"][1]["lit_fraction"].get<double>(), 0.75);

  // Clear errors, exit 1: a camera that is not there, a projector or preview screen that is not.
  EXPECT_EQ(run("white", "127.0.0.4", &out, &err), 1);
  EXPECT_NE(err.find("127.0.0.4"), std::string::npos) << err;
  EXPECT_EQ(cli::RunCli({"capture", project, "--left", "127.0.0.2", "--projector", ":4242",
                         "--width", std::to_string(kProjectorWidth), "--height",
                         std::to_string(kProjectorHeight), "--counts", "16,13,11", "--preview",
                         "--preview-screen", operator_screen.display(), "--preview-frames", "1"},
                        &out, &err),
            1);
  EXPECT_NE(err.find(":4242"), std::string::npos) << err;
  EXPECT_EQ(cli::RunCli({"capture", project, "--left", "127.0.0.2", "--projector",
                         projector.display(), "--width", std::to_string(kProjectorWidth),
                         "--height", std::to_string(kProjectorHeight), "--counts", "16,13,11",
                         "--preview", "--preview-screen", ":4243", "--preview-frames", "1"},
                        &out, &err),
            1);
  EXPECT_NE(err.find(":4243"), std::string::npos) << err;

  // Setting up writes nothing: not even the project folder.
  EXPECT_FALSE(fs::exists(tmp / "scan"));
}

TEST(CapturePreview, PatternsAndFocusMeasure) {
  EXPECT_EQ(ParsePreviewPattern("focus"), PreviewPattern::kFocus);
  EXPECT_THROW(ParsePreviewPattern("grid"), Error);
  const cv::Mat focus = PreviewPatternImage(PreviewPattern::kFocus, 64, 48);
  EXPECT_EQ(cv::countNonZero(focus), 64 * 48 / 2);
  cv::Mat blurred;
  cv::GaussianBlur(focus, blurred, cv::Size(0, 0), 1.0);
  // Blur lowers the measure; a uniform image has none; bit depth does not change it.
  EXPECT_GT(FocusMeasure(focus, 8), FocusMeasure(blurred, 8));
  EXPECT_EQ(FocusMeasure(PreviewPatternImage(PreviewPattern::kWhite, 64, 48), 8), 0);
  cv::Mat focus16;
  focus.convertTo(focus16, CV_16U, 257);
  EXPECT_NEAR(FocusMeasure(focus16, 16), FocusMeasure(focus, 8), 1e-4 * FocusMeasure(focus, 8));
}

}  // namespace
}  // namespace fringe::capture
