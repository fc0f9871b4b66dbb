// Single-frequency schemes with spatial unwrapping (spatial_decode.h): Fourier analysis, the
// quality-guided unwrapping, and OpenCV's SinusoidalPattern captures (PSP, FTP, FAPS with its
// markers) decoded to the true projector column.
#include "fringe/phase/spatial_decode.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "fringe/phase/scheme_presets.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/testing/tool_codecs.h"
#include "fringe/util/error.h"

namespace fringe::phase {
namespace {

using namespace tool_test;
using test::ErrorOf;

// A fringe image A + B cos(2 pi (fx x + fy y) + phi0) + noise (CV_32F).
cv::Mat Fringe(cv::Size size, double fx, double fy, double phi0, double noise, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, noise);
  cv::Mat img(size, CV_32F);
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      img.at<float>(y, x) = static_cast<float>(
          120 + 80 * std::cos(2 * M_PI * (fx * x + fy * y) + phi0) + (noise > 0 ? n(rng) : 0.0));
    }
  }
  return img;
}

TEST(Fourier, CarrierAndPhaseOfAFringeImage) {
  // A tilted fringe of 37.3 px: the carrier to a fraction of a bin; the analytic signal's phase
  // far below one pixel's least-squares noise (the window averages) inside, a few hundredths of a
  // radian near the border (the cut fringe leaks the opposite lobe); B and the band-limited
  // image away from the border, better with the fringe continued past it.
  const cv::Size size(400, 300);
  const double fx = 1 / 37.3, fy = 0.004;
  const cv::Mat img = Fringe(size, fx, fy, 0.7, 2.0, 1);
  const cv::Point2d c = FindCarrier(img);
  EXPECT_NEAR(c.x, fx, 0.05 / 400);
  EXPECT_NEAR(c.y, fy, 0.05 / 300);
  const cv::Mat clean = Fringe(size, fx, fy, 0.7, 0.0, 1);
  for (const int iterations : {0, kFringeContinuationIterations}) {
    const FourierFringe f = FourierAnalysis(img, c, cv::Mat(), iterations);
    double edge = 0, near = 0, inner = 0, worst_b = 0, worst_band = 0;
    for (int y = 0; y < size.height; ++y) {
      for (int x = 0; x < size.width; ++x) {
        const cv::Vec2f z = f.analytic.at<cv::Vec2f>(y, x);
        const double phi = 2 * M_PI * (fx * x + fy * y) + 0.7;
        const double d = std::abs(std::remainder(std::atan2(z[1], z[0]) - phi, 2 * M_PI));
        const int border =
            std::min(std::min(x, size.width - 1 - x), std::min(y, size.height - 1 - y));
        (border >= 80   ? inner
         : border >= 20 ? near
                        : edge) = std::max(border >= 80   ? inner
                                           : border >= 20 ? near
                                                          : edge,
                                           d);
        if (border >= 80) {
          worst_b = std::max(worst_b, std::abs(2 * std::hypot(z[0], z[1]) - 80.0));
          worst_band =
              std::max(worst_band, std::abs(static_cast<double>(f.band_limited.at<float>(y, x)) -
                                            clean.at<float>(y, x)));
        }
      }
    }
    EXPECT_LT(edge, 0.1) << iterations;    // rad, within 20 px of the border
    EXPECT_LT(near, 0.04) << iterations;   // 20-80 px
    EXPECT_LT(inner, 0.01) << iterations;  // one pixel's 4-step least squares: 0.035 rad sigma
    // The continuation keeps B and the band-limited image right farther out.
    EXPECT_LT(worst_b, iterations > 0 ? 0.5 : 2.0) << iterations;  // DN of B = 80
    EXPECT_LT(worst_band, iterations > 0 ? 0.5 : 2.0) << iterations;
  }
}

TEST(Fourier, QualityGuidedUnwrappingFollowsTheRegions) {
  // A ramp of 1/23 cycles per pixel, wrapped, with a wall of invalid pixels splitting the image:
  // two regions, each the ramp up to a whole number of cycles.
  const cv::Size size(120, 80);
  cv::Mat cycles(size, CV_32F), quality(size, CV_32F), valid(size, CV_8U, cv::Scalar(255));
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      const double c = x / 23.0 + y / 97.0;
      cycles.at<float>(y, x) = static_cast<float>(c - std::floor(c));
      quality.at<float>(y, x) = static_cast<float>(1.0 + std::sin(x * 0.3) * std::cos(y * 0.2));
    }
  }
  valid.colRange(60, 63).setTo(0);
  cv::Mat unwrapped, labels;
  const int regions = UnwrapQualityGuided(cycles, quality, valid, 0.4, &unwrapped, &labels);
  ASSERT_EQ(regions, 2);
  for (const int x0 : {0, 63}) {
    const int l = labels.at<int32_t>(0, x0);
    const double k = unwrapped.at<float>(0, x0) - x0 / 23.0;
    EXPECT_NEAR(k, std::round(k), 1e-4);
    for (int y = 0; y < size.height; ++y) {
      for (int x = x0; x < x0 + 57; ++x) {
        ASSERT_EQ(labels.at<int32_t>(y, x), l);
        ASSERT_NEAR(unwrapped.at<float>(y, x) - (x / 23.0 + y / 97.0), k, 1e-4) << x << "," << y;
      }
    }
  }
  EXPECT_EQ(labels.at<int32_t>(5, 61), -1);
  EXPECT_TRUE(std::isnan(unwrapped.at<float>(5, 61)));
}

class SpatialDecode : public ToolCodecDecode {};

// OpenCV's 800 x 600 projector with its defaults (20 periods of 40 px, markers every 56 px), seen
// by a 640 x 480 camera over projector columns 40-760 and rows 30-570 (1.13 projector px per
// camera px), 1 DN of noise at B = 90 DN. Every method decodes to the column within 6 sigma of
// the 3-step least squares (FTP's own noise is far lower: its window averages) plus a quarter
// pixel for the 8-bit patterns and the capture's interpolation; markers' pixels are rejected.
TEST_F(SpatialDecode, OpencvSinusoidalCapturesDecodeToTheProjectorColumn) {
  constexpr double kNoiseDn = 1.0, kModulationDn = 90.0, kSigmas = 6.0, kPatternPx = 0.25;
  for (const char* preset : {"opencv-psp", "opencv-ftp", "opencv-faps"}) {
    SchemeParameters p = Size(800, 600);
    p.counts.assign(1, static_cast<double>(20));
    const PatternScheme s = MakePresetScheme(preset, p);
    ASSERT_TRUE(s.markers.Present());
    const Capture cap = ToolCapture2D(s, dir_ / preset, kNoiseDn, {640, 480}, 40, 760, 30, 570);
    DecodeOptions o;
    o.noise_sigma_dn = kNoiseDn;
    std::vector<FoundMarker> markers;
    DecodeResult r;
    DecodeSpatial(s, cap.images, o, 255, &r, &markers);
    if (std::string(preset) == "opencv-psp") {
      // Decode dispatches to it.
      const DecodeResult via_decode = Decode(s, cap.images, o);
      EXPECT_EQ(cv::countNonZero(r.mask != via_decode.mask), 0) << preset;
    }
    const auto [valid, worst] = Errors(r, cap.truth);
    const double tolerance =
        kSigmas * AbsolutePhaseSigmaPx(s, kNoiseDn, kModulationDn) + kPatternPx;
    EXPECT_GT(valid, 0.95) << preset << ": " << r.summary.BriefReport();
    EXPECT_LT(worst, tolerance) << preset << ": " << r.summary.message;
    // The markers the view holds: 3 images x periods 1..17 inside columns 40..760, 9 rows each.
    EXPECT_GT(markers.size(), 100u) << preset;
    EXPECT_EQ(r.summary.rejected_order_ambiguous, 0) << preset << ": " << r.summary.message;
    EXPECT_NE(r.summary.message.find("1 of 1 regions anchored"), std::string::npos)
        << r.summary.message;
  }
}

TEST_F(SpatialDecode, RowCodingAndOtherSpacings) {
  // Horizontal fringes (OpenCV's horizontal = true), 12 periods of 50 px, markers every 70 px.
  SchemeParameters p = Size(800, 600, true);
  p.counts.assign(1, static_cast<double>(12));
  p.markers = 70;
  const PatternScheme s = MakePresetScheme("opencv-faps", p);
  const Capture cap = ToolCapture2D(s, dir_ / "rows", 1.0, {480, 400}, 20, 580, 40, 760);
  DecodeOptions o;
  o.noise_sigma_dn = 1.0;
  const DecodeResult r = Decode(s, cap.images, o);
  const auto [valid, worst] = Errors(r, cap.truth);
  EXPECT_GT(valid, 0.95) << r.summary.BriefReport();
  EXPECT_LT(worst, 6 * AbsolutePhaseSigmaPx(s, 1.0, 90.0) + 0.25) << r.summary.message;
}

TEST_F(SpatialDecode, WithoutMarkersOrAnchorTheRegionIsRejectedNotGuessed) {
  SchemeParameters p = Size(800, 600);
  p.counts.assign(1, static_cast<double>(20));
  // A view of columns 45-215 (periods 1-5): only image 0's markers, whose group spans periods
  // 0-5; every whole number of periods that keeps the region on the projector fits them.
  const PatternScheme s = MakePresetScheme("opencv-psp", p);
  const Capture cap = ToolCapture2D(s, dir_ / "narrow", 1.0, {200, 300}, 45, 215, 30, 570);
  DecodeOptions o;
  o.noise_sigma_dn = 1.0;
  const DecodeResult r = Decode(s, cap.images, o);
  EXPECT_EQ(r.summary.valid, 0);
  EXPECT_GT(r.summary.rejected_order_ambiguous, 50000);
  EXPECT_NE(r.summary.message.find("without markers that fix their period"), std::string::npos)
      << r.summary.message;
  // OpenCV's setMarkers = false: the patterns are written, the decode says what is missing.
  p.markers = 0;
  const PatternScheme plain = MakePresetScheme("opencv-psp", p);
  const std::string e = ErrorOf([&] { Decode(plain, cap.images, o); });
  EXPECT_NE(e.find("\"spatial\" needs markers"), std::string::npos) << e;
}

TEST(SpatialManifest, MethodsThatDoNotFitNameTheField) {
  nlohmann::json j = SchemeToJson(MakePresetScheme("opencv-ftp", Size(800, 600)));
  EXPECT_EQ(j["unwrapping"], "spatial");
  EXPECT_EQ(j["phase_retrieval"], "ftp");
  EXPECT_EQ(j["markers"]["spacing_px"], 56);
  EXPECT_EQ(SchemeToJson(SchemeFromJson(j, "m.json")), j);
  // Two sets: spatial unwraps one.
  nlohmann::json two = j;
  two["phase_sets"].push_back(two["phase_sets"][0]);
  two["phase_sets"][1]["period_px"] = 800;
  two.erase("images");
  EXPECT_NE(ErrorOf([&] { SchemeFromJson(two, "m.json"); }).find("unwrapping = \"spatial\""),
            std::string::npos);
  // Fourier phase retrieval with a temporal method.
  nlohmann::json ftp = SchemeToJson(MakeScheme("heterodyne-4x3"));
  ftp["phase_retrieval"] = "ftp";
  EXPECT_NE(ErrorOf([&] { SchemeFromJson(ftp, "m.json"); }).find("phase_retrieval"),
            std::string::npos);
  // Markers whose period is not the set's.
  nlohmann::json wrong = j;
  wrong["markers"]["periods"] = 16;
  EXPECT_NE(ErrorOf([&] { SchemeFromJson(wrong, "m.json"); }).find("markers' period"),
            std::string::npos);
  // A flat step that leaves one fringe image.
  nlohmann::json flat = SchemeToJson(MakePresetScheme("slstudio-phaseshift2p1", Size(1280, 800)));
  flat["phase_sets"][0]["flat_steps"] = {1, 2};
  EXPECT_NE(ErrorOf([&] { SchemeFromJson(flat, "m.json"); }).find("flat_steps"), std::string::npos);
}

}  // namespace
}  // namespace fringe::phase
