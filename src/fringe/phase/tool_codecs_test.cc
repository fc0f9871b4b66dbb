// Other tools' codecs as presets (docs/formats.md, "Other tools' codecs"): each preset's images
// equal the tool's patterns as its source computes them, re-implemented here from the tool's
// formula (not through the preset), and a simulated capture with the tool's conventions (its
// quantised patterns, its image order and file names) decodes to the true projector column.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "fringe/io/image_io.h"
#include "fringe/phase/decode.h"
#include "fringe/phase/scheme_presets.h"
#include "fringe/phase/stack_io.h"
#include "fringe/phase/synthetic.h"
#include "fringe/util/error.h"

#ifdef FRINGE_HAVE_STRUCTURED_LIGHT
#include <opencv2/structured_light.hpp>
#endif

namespace fringe::phase {
namespace {

namespace fs = std::filesystem;

// One tool frame: the profile along the coded direction (every row/column is the same).
using Profile = std::vector<uint8_t>;

// The preset's images keyed by the tool's frame number, read from its image names
// ("<prefix><number><suffix>"), as profiles along the phase direction.
std::vector<std::pair<int, Profile>> PresetFrames(const PatternScheme& s,
                                                  const std::string& prefix) {
  const auto images = GeneratePatterns(s);
  const auto names = s.ImageNames();
  std::vector<std::pair<int, Profile>> out;
  for (size_t i = 0; i < images.size(); ++i) {
    EXPECT_EQ(names[i].rfind(prefix, 0), 0u) << names[i];
    const int frame = std::stoi(names[i].substr(prefix.size()));
    Profile p(s.Span());
    for (int u = 0; u < s.Span(); ++u) {
      p[u] = s.direction == FringeDirection::kVertical ? images[i].at<uint8_t>(0, u)
                                                       : images[i].at<uint8_t>(u, 0);
    }
    // Every row (column) repeats the profile.
    const int last =
        s.direction == FringeDirection::kVertical ? images[i].rows - 1 : images[i].cols - 1;
    for (int u = 0; u < s.Span(); u += 97) {
      const uint8_t far = s.direction == FringeDirection::kVertical
                              ? images[i].at<uint8_t>(last, u)
                              : images[i].at<uint8_t>(u, last);
      EXPECT_EQ(far, p[u]);
    }
    out.emplace_back(frame, p);
  }
  return out;
}

int CountDifferences(const Profile& a, const Profile& b) {
  int n = 0;
  for (size_t i = 0; i < a.size(); ++i) n += a[i] != b[i];
  return n;
}

// SLStudio pstools::computePhaseVector (revision 13f41924): float arithmetic, 0.5 (1 + cos(2 pi i
// / pitch - phase)), converted to a byte by truncation.
Profile SlstudioPhaseVector(int length, float phase, float pitch) {
  const float pi = static_cast<float>(M_PI);
  Profile p(length);
  for (int i = 0; i < length; ++i) {
    const float amp = 0.5 * (1 + std::cos(2 * pi * static_cast<float>(i) / pitch - phase));
    p[i] = static_cast<uint8_t>(255.0 * amp);
  }
  return p;
}

SchemeParameters Size(int w, int h, bool horizontal = false) {
  SchemeParameters p;
  p.projector_width = w;
  p.projector_height = h;
  p.horizontal = horizontal;
  return p;
}

TEST(ToolCodecs, SlstudioPhaseShift2x3IsTheToolsPatterns) {
  // 1920 wide: a width where double-precision evaluation would miss SLStudio's bytes.
  for (const auto& [w, h, horizontal] : std::vector<std::tuple<int, int, bool>>{
           {1280, 800, false}, {1920, 1080, false}, {912, 1140, true}}) {
    const PatternScheme s = MakePresetScheme("slstudio-phaseshift2x3", Size(w, h, horizontal));
    const int span = horizontal ? h : w;
    const auto frames = PresetFrames(s, "frameSeq_");
    ASSERT_EQ(frames.size(), 6u);
    const float pi = static_cast<float>(M_PI);
    for (const auto& [frame, profile] : frames) {
      const float phase = 2.0 * pi / 3.0 * (frame % 3);
      const float pitch = frame < 3 ? static_cast<float>(span) / 16.0f : static_cast<float>(span);
      EXPECT_EQ(CountDifferences(profile, SlstudioPhaseVector(span, phase, pitch)), 0)
          << w << "x" << h << " frame " << frame;
    }
  }
}

TEST(ToolCodecs, SlstudioPhaseShift4And3AreTheToolsPatterns) {
  const float pi = static_cast<float>(M_PI);
  const auto frames =
      PresetFrames(MakePresetScheme("slstudio-phaseshift4", Size(1280, 800)), "frameSeq_");
  ASSERT_EQ(frames.size(), 4u);
  for (const auto& [frame, profile] : frames) {
    const float phase = 2.0 * pi / 4.0f * frame;
    EXPECT_EQ(CountDifferences(profile, SlstudioPhaseVector(1280, phase, 1280.0f)), 0) << frame;
  }
  // PhaseShift3 without the tool's random dither: the float profile rounded by convertTo.
  const auto frames3 =
      PresetFrames(MakePresetScheme("slstudio-phaseshift3", Size(1024, 768)), "frameSeq_");
  ASSERT_EQ(frames3.size(), 3u);
  for (const auto& [frame, profile] : frames3) {
    const float phase = 2.0 * pi / 3.0f * frame;
    Profile want(1024);
    for (int i = 0; i < 1024; ++i) {
      const float amp = 0.5 * (1 + std::cos(2 * pi * static_cast<float>(i) / 1024.0f - phase));
      want[i] = cv::saturate_cast<uint8_t>(amp * 255.0f);
    }
    EXPECT_EQ(CountDifferences(profile, want), 0) << frame;
  }
}

TEST(ToolCodecs, SlstudioGrayCodeIsTheToolsPatterns) {
  // White, black, then bit N - p (1-based) of gray(column) for p = 0..9, N = ceil(log2(cols)).
  for (const auto& [w, h, horizontal] : std::vector<std::tuple<int, int, bool>>{
           {1280, 800, false}, {1024, 768, false}, {912, 1140, true}}) {
    const PatternScheme s = MakePresetScheme("slstudio-graycode", Size(w, h, horizontal));
    const int span = horizontal ? h : w;
    const int shown = horizontal ? 6 : 10;
    const int nbits = static_cast<int>(std::ceil(std::log2(static_cast<double>(span))));
    const auto frames = PresetFrames(s, "frameSeq_");
    ASSERT_EQ(static_cast<int>(frames.size()), 2 + shown);
    for (const auto& [frame, profile] : frames) {
      Profile want(span);
      for (int j = 0; j < span; ++j) {
        if (frame < 2) {
          want[j] = frame == 0 ? 255 : 0;
        } else {
          const unsigned gray = (static_cast<unsigned>(j) >> 1) ^ static_cast<unsigned>(j);
          want[j] = (gray & (1u << (nbits - (frame - 2) - 1))) ? 255 : 0;
        }
      }
      EXPECT_EQ(CountDifferences(profile, want), 0) << w << "x" << h << " frame " << frame;
    }
  }
  EXPECT_THROW(MakePresetScheme("slstudio-graycode", Size(500, 400)), Error);
}

// OpenCV GrayCodePattern::generate (opencv_contrib ce02ce7c), re-implemented: for column j and
// bit k (0 = least significant) the flag is bit k xor bit k+1 of j; image 2 (n - 1 - k) shows it,
// the next image its inverse; column images, then row images; the capture sample appends white
// and black. Frame numbers are 1-based (pattern_cam1_im<i+1>.png).
std::vector<Profile> OpencvGrayFrames(int width, int height, bool rows) {
  const int ncol = static_cast<int>(std::ceil(std::log(double(width)) / std::log(2.0)));
  const int nrow = static_cast<int>(std::ceil(std::log(double(height)) / std::log(2.0)));
  std::vector<Profile> frames(2 * (ncol + nrow) + 2);
  for (int f = 0; f < 2 * ncol; ++f) frames[f].assign(width, 0);
  for (int f = 2 * ncol; f < 2 * (ncol + nrow); ++f) frames[f].assign(height, 0);
  for (int j = 0; j < width; ++j) {
    for (int k = 0; k < ncol; ++k) {
      const int flag = ((j >> k) & 1) != ((j >> (k + 1)) & 1);
      frames[2 * ncol - 2 * k - 2][j] = flag ? 255 : 0;
      frames[2 * ncol - 2 * k - 1][j] = flag ? 0 : 255;
    }
  }
  for (int i = 0; i < height; ++i) {
    for (int k = 0; k < nrow; ++k) {
      const int flag = ((i >> k) & 1) != ((i >> (k + 1)) & 1);
      frames[2 * ncol + 2 * nrow - 2 * k - 2][i] = flag ? 255 : 0;
      frames[2 * ncol + 2 * nrow - 2 * k - 1][i] = flag ? 0 : 255;
    }
  }
  frames[2 * (ncol + nrow)].assign(rows ? height : width, 255);
  frames[2 * (ncol + nrow) + 1].assign(rows ? height : width, 0);
  return frames;
}

TEST(ToolCodecs, OpencvGrayCodePatternIsTheToolsPatterns) {
  for (const bool horizontal : {false, true}) {
    const PatternScheme s = MakePresetScheme("opencv-graycode", Size(1024, 768, horizontal));
    const auto want = OpencvGrayFrames(1024, 768, horizontal);
    const auto frames = PresetFrames(s, "pattern_cam1_im");
    ASSERT_EQ(frames.size(), 2u * 10 + 2);  // 10 bits for 1024 columns and for 768 rows
    for (const auto& [frame, profile] : frames) {
      EXPECT_EQ(CountDifferences(profile, want[frame - 1]), 0) << "frame " << frame;
    }
  }
#ifdef FRINGE_HAVE_STRUCTURED_LIGHT
  // And the real thing: OpenCV's own generator, column images of a 1280 x 800 projector.
  cv::structured_light::GrayCodePattern::Params params;
  params.width = 1280;
  params.height = 800;
  auto gray = cv::structured_light::GrayCodePattern::create(params);
  std::vector<cv::Mat> theirs;
  gray->generate(theirs);
  cv::Mat white, black;
  gray->getImagesForShadowMasks(black, white);
  theirs.push_back(white);
  theirs.push_back(black);
  const PatternScheme s = MakePresetScheme("opencv-graycode", Size(1280, 800));
  const auto ours = GeneratePatterns(s);
  const auto names = s.ImageNames();
  for (size_t i = 0; i < ours.size(); ++i) {
    const int frame = std::stoi(names[i].substr(std::string("pattern_cam1_im").size()));
    EXPECT_EQ(cv::norm(ours[i], theirs[frame - 1], cv::NORM_INF), 0) << names[i];
  }
#endif
}

TEST(ToolCodecs, OpencvPspIsTheToolsPatterns) {
  // SinusoidalPattern::generate: saturate_cast<uchar>(127.5 + 127.5 sin(2 pi f j + i shift)),
  // period = width / nbrOfPeriods (integers), f = float(1 / period), shift = float(2 pi / 3).
  const int width = 800;
  const PatternScheme s = MakePresetScheme("opencv-psp", Size(width, 600));
  const auto frames = PresetFrames(s, "");
  ASSERT_EQ(frames.size(), 3u);
  const float f = 1.0f / static_cast<float>(width / 1);
  const float shift = static_cast<float>(2 * CV_PI / 3);
  for (const auto& [frame, profile] : frames) {
    Profile want(width);
    for (int j = 0; j < width; ++j) {
      want[j] =
          cv::saturate_cast<uint8_t>(127.5f + 127.5f * std::sin(2 * CV_PI * f * j + frame * shift));
    }
    EXPECT_EQ(CountDifferences(profile, want), 0) << frame;
  }
  // Twenty periods (OpenCV's default) generate, but fringe cannot unwrap them absolutely: a clear
  // error, not a wrong decode.
  SchemeParameters p = Size(width, 600);
  p.counts = {20};
  EXPECT_THROW(MakePresetScheme("opencv-psp", p), Error);
#ifdef FRINGE_HAVE_STRUCTURED_LIGHT
  cv::structured_light::SinusoidalPattern::Params params;
  params.width = width;
  params.height = 600;
  params.nbrOfPeriods = 1;
  params.methodId = cv::structured_light::PSP;
  auto sin = cv::structured_light::SinusoidalPattern::create(
      cv::makePtr<cv::structured_light::SinusoidalPattern::Params>(params));
  std::vector<cv::Mat> theirs;
  sin->generate(theirs);
  const auto ours = GeneratePatterns(s);
  ASSERT_EQ(theirs.size(), ours.size());
  for (size_t i = 0; i < ours.size(); ++i) {
    EXPECT_EQ(cv::norm(ours[i], theirs[i], cv::NORM_INF), 0) << i;
  }
#endif
}

TEST(ToolCodecs, SlmasterSinusCompleGrayIsTheToolsPatterns) {
  // sinusCompleGraycodePattern.cpp (58e73231): N images of uchar(127.5 + 127.5 cos(2 pi (k mod
  // P) / P - pi + 2 pi i / N)) with P = width / nbrOfPeriods; then the reflected sequence {0, 255}
  // -> {0, 255, 255, 0} -> ... over blocks of width / size px, log2(nbrOfPeriods) + 1 images.
  for (const auto& [w, periods, steps] :
       std::vector<std::tuple<int, int, int>>{{1280, 32, 4}, {1920, 16, 3}, {1024, 64, 6}}) {
    SchemeParameters p = Size(w, 720);
    p.counts = {static_cast<double>(periods)};
    p.steps = steps;
    const PatternScheme s = MakePresetScheme("slmaster-sinus-comple-gray", p);
    const auto ours = GeneratePatterns(s);
    const int pp = w / periods;
    std::vector<Profile> want;
    for (int i = 0; i < steps; ++i) {
      Profile prof(w);
      const double shift = CV_2PI / steps * i;
      for (int k = 0; k < w; ++k) {
        const double wrapped = (k % pp) / static_cast<double>(pp) * CV_2PI - CV_PI;
        prof[k] = static_cast<uint8_t>(127.5 + 127.5 * std::cos(wrapped + shift));
      }
      want.push_back(prof);
    }
    std::vector<uint8_t> sequence = {0, 255};
    const int gray_images = static_cast<int>(std::log2(periods)) + 1;
    for (int i = 0; i < gray_images; ++i) {
      Profile prof(w, 0);
      const int block = static_cast<int>(w / sequence.size());
      for (size_t j = 0; j < sequence.size(); ++j) {
        std::fill_n(prof.begin() + j * block, block, sequence[j]);
      }
      for (int j = static_cast<int>(sequence.size()) - 1; j >= 0; --j) {
        sequence.push_back(sequence[j]);
      }
      want.push_back(prof);
    }
    ASSERT_EQ(ours.size(), want.size());
    for (size_t i = 0; i < ours.size(); ++i) {
      Profile prof(w);
      for (int k = 0; k < w; ++k) prof[k] = ours[i].at<uint8_t>(0, k);
      EXPECT_EQ(CountDifferences(prof, want[i]), 0) << w << " image " << i;
    }
  }
  SchemeParameters p = Size(1280, 720);
  p.counts = {40};  // not a power of two: the tool's own Gray code would not align
  EXPECT_THROW(MakePresetScheme("slmaster-sinus-comple-gray", p), Error);
}

// A capture of the tool's own 8-bit patterns: each camera pixel sees projector coordinate u
// (linear across the image), the projected byte interpolated linearly between projector pixels,
// I = A + B (2 byte / 255 - 1) + noise; written with the scheme's (the tool's) file names and
// read back by name.
struct Capture {
  cv::Mat truth;  // projector coordinate per camera pixel
  std::vector<cv::Mat> images;
};

Capture ToolCapture(const PatternScheme& s, const fs::path& dir, double noise_dn) {
  const cv::Size size(240, 24);
  Capture cap;
  cap.truth = LinearProjectorMap(s, size);
  const auto patterns = GeneratePatterns(s);
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, noise_dn);
  fs::create_directories(dir);
  const auto names = s.ImageNames();
  for (size_t i = 0; i < patterns.size(); ++i) {
    cv::Mat img(size, CV_8U);
    for (int r = 0; r < size.height; ++r) {
      for (int c = 0; c < size.width; ++c) {
        const double u = cap.truth.at<float>(r, c);
        const int u0 = std::min(static_cast<int>(std::floor(u)), s.Span() - 2);
        const double t = u - u0;
        auto byte = [&](int x) {
          return s.direction == FringeDirection::kVertical ? patterns[i].at<uint8_t>(0, x)
                                                           : patterns[i].at<uint8_t>(x, 0);
        };
        const double p = ((1 - t) * byte(u0) + t * byte(u0 + 1)) / 255.0;
        const double v = 120.0 + 90.0 * (2 * p - 1) + noise(rng);
        img.at<uint8_t>(r, c) = cv::saturate_cast<uint8_t>(v);
      }
    }
    io::WriteImage(dir / names[i], img);
  }
  cap.images = ReadStack(dir, s);
  return cap;
}

// Valid fraction and the largest error (projector px) over valid pixels.
std::pair<double, double> Errors(const DecodeResult& r, const cv::Mat& truth) {
  int valid = 0;
  double worst = 0;
  for (int y = 0; y < truth.rows; ++y) {
    for (int x = 0; x < truth.cols; ++x) {
      if (!r.mask.at<uint8_t>(y, x)) continue;
      ++valid;
      worst = std::max<double>(worst,
                               std::fabs(r.absolute_phase.at<float>(y, x) - truth.at<float>(y, x)));
    }
  }
  return {static_cast<double>(valid) / truth.total(), worst};
}

class ToolCodecDecode : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("fringe_tool_codecs_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(ToolCodecDecode, PhaseShiftCodecsDecodeToTheProjectorColumn) {
  // Noise 1 DN at B = 90 DN: the decoder's own noise model (AbsolutePhaseSigmaPx) gives the
  // coordinate's standard deviation; the largest error over ~5000 pixels stays within 6 sigma,
  // plus a quarter pixel for the patterns' 8-bit steps and the capture's interpolation.
  constexpr double kNoiseDn = 1.0, kModulationDn = 90.0, kSigmas = 6.0, kPatternPx = 0.25;
  for (const char* preset : {"slstudio-phaseshift2x3", "slstudio-phaseshift4", "opencv-psp",
                             "slmaster-sinus-comple-gray"}) {
    const PatternScheme s = MakePresetScheme(preset, Size(1280, 800));
    const double tolerance_px =
        kSigmas * AbsolutePhaseSigmaPx(s, kNoiseDn, kModulationDn) + kPatternPx;
    struct {
      const char* preset;
      double tolerance_px;
    } c{preset, tolerance_px};
    const Capture cap = ToolCapture(s, dir_ / c.preset, kNoiseDn);
    DecodeOptions o;
    o.noise_sigma_dn = 1.0;
    const DecodeResult r = Decode(s, cap.images, o);
    const auto [valid, worst] = Errors(r, cap.truth);
    EXPECT_GT(valid, 0.97) << c.preset << ": " << r.summary.BriefReport();
    EXPECT_LT(worst, c.tolerance_px) << c.preset;
  }
}

TEST_F(ToolCodecDecode, GrayCodecsDecodeToTheStripe) {
  // Pure Gray code: the coordinate is the decoded stripe's centre, within half a stripe of the
  // truth (plus the camera pixels that straddle a stripe edge, off by one stripe at most).
  for (const char* preset : {"slstudio-graycode", "opencv-graycode"}) {
    const PatternScheme s = MakePresetScheme(preset, Size(1280, 800));
    const Capture cap = ToolCapture(s, dir_ / preset, 2.0);
    const DecodeResult r = Decode(s, cap.images);
    const auto [valid, worst] = Errors(r, cap.truth);
    EXPECT_GT(valid, 0.97) << preset << ": " << r.summary.BriefReport();
    const double stripe = s.GrayPeriod();
    EXPECT_LE(worst, 1.5 * stripe + 1e-3) << preset;
    int within_half = 0, valid_n = 0;
    for (int y = 0; y < cap.truth.rows; ++y) {
      for (int x = 0; x < cap.truth.cols; ++x) {
        if (!r.mask.at<uint8_t>(y, x)) continue;
        ++valid_n;
        within_half += std::fabs(r.absolute_phase.at<float>(y, x) - cap.truth.at<float>(y, x)) <=
                       0.5 * stripe + 0.5;
      }
    }
    EXPECT_GT(static_cast<double>(within_half) / valid_n, 0.95) << preset;
  }
}

TEST_F(ToolCodecDecode, GrayPairsDecideWithoutAGlobalThreshold) {
  // A capture whose brightness falls to a tenth across the image: pairs still decide each bit;
  // dark regions are not lost to a global level.
  const PatternScheme s = MakePresetScheme("opencv-graycode", Size(1024, 768));
  Capture cap = ToolCapture(s, dir_ / "ramp", 0.5);
  for (auto& img : cap.images) {
    for (int y = 0; y < img.rows; ++y) {
      for (int x = 0; x < img.cols; ++x) {
        const double gain = 1.0 - 0.85 * x / (img.cols - 1.0);
        img.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(img.at<uint8_t>(y, x) * gain);
      }
    }
  }
  DecodeOptions o;
  o.noise_sigma_dn = 0.5;
  const DecodeResult r = Decode(s, cap.images, o);
  const auto [valid, worst] = Errors(r, cap.truth);
  EXPECT_GT(valid, 0.97) << r.summary.BriefReport();
  EXPECT_LE(worst, 1.5);
}

TEST(ToolCodecs, ManifestRoundTripAndBounds) {
  for (const auto& name : ToolPresetNames()) {
    const PatternScheme s = MakePresetScheme(name, Size(1280, 800));
    const PatternScheme back = SchemeFromJson(SchemeToJson(s), name);
    EXPECT_EQ(SchemeToJson(back), SchemeToJson(s)) << name;
    const auto a = GeneratePatterns(s), b = GeneratePatterns(back);
    ASSERT_EQ(a.size(), b.size());
    for (size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(cv::norm(a[i], b[i], cv::NORM_INF), 0) << name << " image " << i;
    }
  }
  nlohmann::json j = SchemeToJson(MakePresetScheme("opencv-graycode", Size(1024, 768)));
  j["gray_code"]["period_px"] = 0.5;
  EXPECT_THROW(SchemeFromJson(j, "m.json"), Error);
  j = SchemeToJson(MakePresetScheme("opencv-graycode", Size(1024, 768)));
  j["quantization"] = "ceil";
  try {
    SchemeFromJson(j, "m.json");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("m.json.quantization"), std::string::npos) << e.what();
  }
  j = SchemeToJson(MakePresetScheme("opencv-graycode", Size(1024, 768)));
  j["gray_code"]["inverted"] = false;
  j["white_frame"] = false;
  j["dark_frame"] = false;
  j.erase("images");
  EXPECT_THROW(SchemeFromJson(j, "m.json"), Error);  // nothing to threshold the bits by
  // Tool codecs fix their own periods and steps.
  SchemeParameters p = Size(1280, 800);
  p.steps = 4;
  EXPECT_THROW(MakePresetScheme("slstudio-phaseshift2x3", p), Error);
}

TEST(ToolCodecs, AnUnknownNameListsTheToolCodecs) {
  try {
    SchemeFromArgument("slstudio-phaseshift9", {});
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("slstudio-phaseshift2x3"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("heterodyne-4x3"), std::string::npos) << e.what();
  }
}

TEST(ToolCodecs, ImageNamesNumberTheToolsFrames) {
  SchemeParameters p = Size(1280, 800);
  p.image_names = "pattern_cam2_im%d.png";
  const PatternScheme s = MakePresetScheme("opencv-graycode", p);
  // 11 column bits x 2, then 10 row bits x 2 not used, then white and black.
  EXPECT_EQ(s.ImageNames().front(), "pattern_cam2_im1.png");
  EXPECT_EQ(s.ImageNames()[21], "pattern_cam2_im22.png");
  EXPECT_EQ(s.ImageNames()[22], "pattern_cam2_im43.png");
  EXPECT_EQ(s.ImageNames()[23], "pattern_cam2_im44.png");
  const PatternScheme g = MakePresetScheme("slstudio-graycode", Size(1280, 800));
  EXPECT_EQ(g.WhiteImageIndex(), 0);
  EXPECT_EQ(g.ImageNames()[0], "frameSeq_0.bmp");
  EXPECT_EQ(g.ImageNames()[11], "frameSeq_11.bmp");
}

}  // namespace
}  // namespace fringe::phase
