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
#include "fringe/testing/tool_codecs.h"
#include "fringe/util/error.h"

#ifdef FRINGE_HAVE_STRUCTURED_LIGHT
#include <opencv2/structured_light.hpp>
#endif

namespace fringe::phase {
namespace {

namespace fs = std::filesystem;
using namespace tool_test;

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
  // Twenty periods (OpenCV's default) are unwrapped spatially, with OpenCV's markers (on by
  // default); the images are tested with the markers below (OpencvSinusoidalWithMarkers...).
  SchemeParameters p = Size(width, 600);
  p.counts.assign(1, static_cast<double>(20));
  EXPECT_EQ(MakePresetScheme("opencv-psp", p).Method(), Unwrapping::kSpatial);
  p.counts.assign(1, static_cast<double>(2.5));
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
    p.counts.assign(1, static_cast<double>(periods));
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
  p.counts.assign(
      1, static_cast<double>(40));  // not a power of two: the tool's own Gray code would not align
  EXPECT_THROW(MakePresetScheme("slmaster-sinus-comple-gray", p), Error);
}

TEST(ToolCodecs, SlstudioPhaseShiftNStepIsTheToolsPatterns) {
  // CodecPhaseShiftNStep (13f41924): 9 steps at phase 2 pi / 9 i, pitch cols / 8, then 3 cue
  // steps at phase 2 pi / 3 i, pitch cols; rows with CodecDirVertical.
  const float pi = static_cast<float>(M_PI);
  for (const auto& [w, h, horizontal] : std::vector<std::tuple<int, int, bool>>{
           {1280, 800, false}, {1920, 1080, false}, {912, 1140, true}}) {
    const PatternScheme s = MakePresetScheme("slstudio-phaseshiftnstep", Size(w, h, horizontal));
    EXPECT_EQ(s.Method(), Unwrapping::kHierarchical);
    const int span = horizontal ? h : w;
    const auto frames = PresetFrames(s, "frameSeq_");
    ASSERT_EQ(frames.size(), 12u);
    for (const auto& [frame, profile] : frames) {
      const unsigned n_steps = 9, n_phases = 8;
      const float phase = frame < 9 ? 2.0 * pi / n_steps * frame : 2.0 * pi / 3.0 * (frame - 9);
      const float pitch = frame < 9 ? static_cast<float>(span) / static_cast<float>(n_phases)
                                    : static_cast<float>(span);
      EXPECT_EQ(CountDifferences(profile, SlstudioPhaseVector(span, phase, pitch)), 0)
          << w << "x" << h << " frame " << frame;
    }
  }
}

TEST(ToolCodecs, SlstudioPhaseShift2p1And3FastWrapAreTheToolsPatterns) {
  const float pi = static_cast<float>(M_PI);
  // CodecPhaseShift2p1 (9e0bc5ec): phase vectors at 0 and pi/2 over one period, then a flat
  // frame setTo(0.5 * 255.0): OpenCV rounds 127.5 to even, 128.
  for (const int w : {1280, 1024, 1920}) {
    const auto frames =
        PresetFrames(MakePresetScheme("slstudio-phaseshift2p1", Size(w, 720)), "frameSeq_");
    ASSERT_EQ(frames.size(), 3u);
    for (const auto& [frame, profile] : frames) {
      const Profile want = frame == 0   ? SlstudioPhaseVector(w, 0.0f, static_cast<float>(w))
                           : frame == 1 ? SlstudioPhaseVector(w, pi / 2.0, static_cast<float>(w))
                                        : Profile(w, cv::saturate_cast<uint8_t>(0.5 * 255.0));
      EXPECT_EQ(CountDifferences(profile, want), 0) << w << " frame " << frame;
    }
  }
  // CodecPhaseShift3FastWrap (13f41924): phase 2 pi / float(N) i, pitch cols, N = 3.
  const auto frames =
      PresetFrames(MakePresetScheme("slstudio-phaseshift3fastwrap", Size(1280, 800)), "frameSeq_");
  ASSERT_EQ(frames.size(), 3u);
  for (const auto& [frame, profile] : frames) {
    const float phase = 2.0 * pi / static_cast<float>(3) * frame;
    EXPECT_EQ(CountDifferences(profile, SlstudioPhaseVector(1280, phase, 1280.0f)), 0) << frame;
  }
  // Both encoders code columns whatever the direction.
  EXPECT_THROW(MakePresetScheme("slstudio-phaseshift2p1", Size(1280, 800, true)), Error);
  EXPECT_THROW(MakePresetScheme("slstudio-phaseshift3fastwrap", Size(1280, 800, true)), Error);
}

TEST(ToolCodecs, SlmasterThreeFrequencyHeterodyneIsTheToolsPatterns) {
  // threeFrequencyHeterodynePattern.cpp (58e73231, generate unchanged in f300566f): for weeks in
  // {N, N - 6, N - 11}: pixelsPerPeriod = float(width) / weeks, shiftVal = float(CV_2PI /
  // shiftTime * i), denom = k / ppp - floor(k / ppp) in float, wrapped = float((2 denom - 1)
  // CV_PI), uchar(127.5 + 127.5 cos(wrapped + shiftVal)) with the float cos of SLMaster's MSVC
  // build; horizontal: the same over the height, transposed.
  for (const auto& [w, h, periods, steps, horizontal] :
       std::vector<std::tuple<int, int, int, int, bool>>{{1280, 720, 32, 4, false},
                                                         {1920, 1080, 24, 3, false},
                                                         {1024, 768, 40, 5, false},
                                                         {1280, 720, 16, 4, true}}) {
    SchemeParameters p = Size(w, h, horizontal);
    p.counts.assign(1, static_cast<double>(periods));
    p.steps = steps;
    const PatternScheme s = MakePresetScheme("slmaster-three-frequency-heterodyne", p);
    EXPECT_EQ(s.Method(), Unwrapping::kHeterodyne);
    const int width = horizontal ? h : w;
    const auto ours = GeneratePatterns(s);
    ASSERT_EQ(static_cast<int>(ours.size()), 3 * steps);
    const int weeks[3] = {periods, periods - 6, periods - 11};
    int image = 0;
    for (int set = 0; set < 3; ++set) {
      const float ppp = static_cast<float>(width) / weeks[set];
      for (int i = 0; i < steps; ++i, ++image) {
        const float shift = CV_2PI / steps * i;
        Profile want(width), got(width);
        for (int k = 0; k < width; ++k) {
          const float denom = k / ppp - std::floor(k / ppp);
          const float wrapped = (2 * denom - 1) * CV_PI;
          const float arg = wrapped + shift;
          want[k] = static_cast<uint8_t>(127.5 + 127.5 * std::cos(arg));  // float overload
          got[k] = horizontal ? ours[image].at<uint8_t>(k, 0) : ours[image].at<uint8_t>(0, k);
        }
        EXPECT_EQ(CountDifferences(got, want), 0)
            << w << "x" << h << " periods " << periods << " image " << image;
      }
    }
  }
  SchemeParameters p = Size(1280, 720);
  p.counts.assign(1, static_cast<double>(11));  // the third set would have no period
  EXPECT_THROW(MakePresetScheme("slmaster-three-frequency-heterodyne", p), Error);
}

// OpenCV SinusoidalPattern::generate (opencv_contrib 0184e33d) with setMarkers, re-implemented:
// the three sinusoids, then per pattern i, j < n = periods / 3, k < (side - 10) / m the cross at
// Mat position (x, y) = (10 + k m + j (m / n), 3 period / 4 + j period + i period n - i period /
// 3) and its four neighbours, on the (transposed for horizontal) pattern.
std::vector<cv::Mat> OpencvSinusoidal(int width, int height, int periods, bool horizontal, int m) {
  const float mean = 127.5, amplitude = 127.5, shift = static_cast<float>(2 * CV_PI / 3);
  const int n = periods / 3;
  const int period = horizontal ? height / periods : width / periods;
  // m = 0 is OpenCV's setMarkers = false: no crosses, and no division by it.
  const int per_row = m > 0 ? static_cast<int>(std::floor(
                                  static_cast<float>(((horizontal ? width : height) - 10) / m)))
                            : 0;
  const float frequency = static_cast<float>(1) / period;
  std::vector<cv::Mat> out;
  for (int i = 0; i < 3; ++i) {
    cv::Mat pattern(height, width, CV_8UC1);
    if (horizontal) pattern = pattern.t();
    for (int j = 0; j < pattern.cols; ++j) {
      const uint8_t v = cv::saturate_cast<uchar>(
          mean + amplitude * std::sin(2 * CV_PI * frequency * j + i * shift));
      pattern.col(j).setTo(v);
    }
    if (m > 0) {
      for (int j = 0; j < n; ++j) {
        for (int k = 0; k < per_row; ++k) {
          const int x = 10 + k * m + j * (m / n);
          const int y = 3 * period / 4 + j * period + i * period * n - i * period / 3;
          for (const auto& [dx, dy] : {std::pair{0, 0}, {0, -1}, {-1, 0}, {0, 1}, {1, 0}}) {
            pattern.at<uchar>(x + dx, y + dy) = 255;
          }
        }
      }
    }
    out.push_back(horizontal ? cv::Mat(pattern.t()) : pattern);
  }
  return out;
}

TEST(ToolCodecs, OpencvSinusoidalWithMarkersIsTheToolsPatterns) {
  for (const char* preset : {"opencv-psp", "opencv-ftp", "opencv-faps"}) {
    for (const auto& [w, h, periods, m, horizontal] :
         std::vector<std::tuple<int, int, int, int, bool>>{
             {800, 600, 20, 56, false}, {1280, 800, 32, 70, false}, {800, 600, 12, 56, true}}) {
      SchemeParameters p = Size(w, h, horizontal);
      p.counts.assign(1, static_cast<double>(periods));
      p.markers = m;
      const PatternScheme s = MakePresetScheme(preset, p);
      EXPECT_EQ(s.Method(), Unwrapping::kSpatial);
      const auto ours = GeneratePatterns(s);
      const auto want = OpencvSinusoidal(w, h, periods, horizontal, m);
      ASSERT_EQ(ours.size(), 3u);
      for (int i = 0; i < 3; ++i) {
        EXPECT_EQ(cv::norm(ours[i], want[i], cv::NORM_INF), 0)
            << preset << " " << w << "x" << h << " image " << i;
      }
    }
  }
  // OpenCV's setMarkers = false: --markers 0.
  SchemeParameters p = Size(800, 600);
  p.markers = 0;
  const auto plain = GeneratePatterns(MakePresetScheme("opencv-ftp", p));
  const auto want = OpencvSinusoidal(800, 600, 20, false, 0);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(cv::norm(plain[i], want[i], cv::NORM_INF), 0) << i;
#ifdef FRINGE_HAVE_STRUCTURED_LIGHT
  // And OpenCV's own generator, with markers at its default spacing.
  cv::structured_light::SinusoidalPattern::Params params;
  params.width = 800;
  params.height = 600;
  params.nbrOfPeriods = 20;
  params.setMarkers = true;
  params.methodId = cv::structured_light::FAPS;
  auto sin = cv::structured_light::SinusoidalPattern::create(
      cv::makePtr<cv::structured_light::SinusoidalPattern::Params>(params));
  std::vector<cv::Mat> theirs;
  sin->generate(theirs);
  const auto ours = GeneratePatterns(MakePresetScheme("opencv-faps", Size(800, 600)));
  ASSERT_EQ(theirs.size(), ours.size());
  for (size_t i = 0; i < ours.size(); ++i) {
    EXPECT_EQ(cv::norm(ours[i], theirs[i], cv::NORM_INF), 0) << i;
  }
#endif
}

TEST(ToolCodecs, InvertedGrayCodeWithPhaseSetsIsTheFormula) {
  // A manifest's complementary Gray code with inverted images and white/black frames (SLMaster's
  // code with inverses): bit b of gray(floor(2 v / P)) >> ... per image, each followed by its
  // inverse, then white and black.
  nlohmann::json j = SchemeToJson(MakeScheme("gray+4", 1280, 800));
  j["gray_code"]["inverted"] = true;
  j["white_frame"] = true;
  j["dark_frame"] = true;
  j.erase("images");
  const PatternScheme s = SchemeFromJson(j, "inverted.json");
  const int bits = s.gray_bits;
  const double period = s.phase_sets[0].period_px;
  ASSERT_EQ(s.NumImages(), 4 + 2 * (bits + 1) + 2);
  const auto images = GeneratePatterns(s);
  for (int b = 0; b <= bits; ++b) {
    Profile want(1280), inverse(1280), got(1280), got_inverse(1280);
    for (int u = 0; u < 1280; ++u) {
      const unsigned half = static_cast<unsigned>(std::floor(2.0 * (u + 0.5) / period));
      const unsigned gray = half ^ (half >> 1);
      const bool bright = (gray >> (bits - b)) & 1u;
      want[u] = bright ? 255 : 0;
      inverse[u] = bright ? 0 : 255;
      got[u] = images[s.GrayImageIndex(b)].at<uint8_t>(0, u);
      got_inverse[u] = images[s.GrayInverseIndex(b)].at<uint8_t>(0, u);
    }
    EXPECT_EQ(CountDifferences(got, want), 0) << "bit " << b;
    EXPECT_EQ(CountDifferences(got_inverse, inverse), 0) << "bit " << b;
  }
  EXPECT_EQ(cv::countNonZero(images[s.WhiteImageIndex()] != 255), 0);
  EXPECT_EQ(cv::countNonZero(images[s.DarkImageIndex()]), 0);
}

TEST_F(ToolCodecDecode, PhaseShiftCodecsDecodeToTheProjectorColumn) {
  // Noise 1 DN at B = 90 DN: the decoder's own noise model (AbsolutePhaseSigmaPx) gives the
  // coordinate's standard deviation; the largest error over ~5000 pixels stays within 6 sigma,
  // plus a quarter pixel for the patterns' 8-bit steps and the capture's interpolation.
  constexpr double kNoiseDn = 1.0, kModulationDn = 90.0, kSigmas = 6.0, kPatternPx = 0.25;
  for (const char* preset :
       {"slstudio-phaseshift2x3", "slstudio-phaseshift4", "slstudio-phaseshift3fastwrap",
        "slstudio-phaseshift2p1", "slstudio-phaseshiftnstep", "opencv-psp",
        "slmaster-sinus-comple-gray", "slmaster-three-frequency-heterodyne"}) {
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

TEST_F(ToolCodecDecode, InvertedGrayPairsWithPhaseSetsDecodeAndReferenceFramesMask) {
  // Complementary Gray code with inverted images and white/black frames beside a 4-step set: each
  // bit from its pair, so a capture whose brightness falls to 15 % across the image decodes
  // everywhere; pixels where white and black do not differ (here: the first 40 columns, where
  // the test overwrites the white frame) are masked, whatever the phase set says.
  nlohmann::json j = SchemeToJson(MakeScheme("gray+4", 1024, 768));
  j["gray_code"]["inverted"] = true;
  j["white_frame"] = true;
  j["dark_frame"] = true;
  j.erase("images");
  const PatternScheme s = SchemeFromJson(j, "inverted.json");
  Capture cap = ToolCapture(s, dir_ / "inverted", 0.5);
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
  EXPECT_LT(worst, 6 * AbsolutePhaseSigmaPx(s, 0.5, 0.15 * 90) + 0.25);
  cap.images[s.DarkImageIndex()].colRange(0, 40).copyTo(
      cap.images[s.WhiteImageIndex()].colRange(0, 40));
  const DecodeResult masked = Decode(s, cap.images, o);
  EXPECT_EQ(cv::countNonZero(masked.mask.colRange(0, 40)), 0);
  const int before = cv::countNonZero(r.mask.colRange(0, 40));
  EXPECT_GT(before, 0);
  EXPECT_EQ(masked.summary.rejected_low_modulation, r.summary.rejected_low_modulation + before);
  EXPECT_EQ(masked.summary.valid, r.summary.valid - before);
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
