// Helpers shared by the tests of other tools' codecs (tool_codecs_test.cc, spatial_decode_test.cc):
// the preset's images as the tool's frames, SLStudio's profile re-implemented, and simulated
// captures of a tool's 8-bit patterns read back by the tool's file names.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "fringe/io/image_io.h"
#include "fringe/phase/decode.h"
#include "fringe/phase/scheme_presets.h"
#include "fringe/phase/stack_io.h"
#include "fringe/phase/synthetic.h"

namespace fringe::phase::tool_test {

namespace fs = std::filesystem;

// One tool frame: the profile along the coded direction (every row/column is the same).
using Profile = std::vector<uint8_t>;

// The preset's images keyed by the tool's frame number, read from its image names
// ("<prefix><number><suffix>"), as profiles along the phase direction.
inline std::vector<std::pair<int, Profile>> PresetFrames(const PatternScheme& s,
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

inline int CountDifferences(const Profile& a, const Profile& b) {
  int n = 0;
  for (size_t i = 0; i < a.size(); ++i) n += a[i] != b[i];
  return n;
}

// SLStudio pstools::computePhaseVector (revision 13f41924): float arithmetic, 0.5 (1 + cos(2 pi i
// / pitch - phase)), converted to a byte by truncation.
inline Profile SlstudioPhaseVector(int length, float phase, float pitch) {
  const float pi = static_cast<float>(M_PI);
  Profile p(length);
  for (int i = 0; i < length; ++i) {
    const float amp = 0.5 * (1 + std::cos(2 * pi * static_cast<float>(i) / pitch - phase));
    p[i] = static_cast<uint8_t>(255.0 * amp);
  }
  return p;
}

inline SchemeParameters Size(int w, int h, bool horizontal = false) {
  SchemeParameters p;
  p.projector_width = w;
  p.projector_height = h;
  p.horizontal = horizontal;
  return p;
}

// A capture of the tool's own 8-bit patterns: each camera pixel sees projector coordinate u
// (linear across the image), the projected byte interpolated linearly between projector pixels,
// I = A + B (2 byte / 255 - 1) + noise; written with the scheme's (the tool's) file names and
// read back by name.
struct Capture {
  cv::Mat truth;  // projector coordinate per camera pixel
  std::vector<cv::Mat> images;
};

inline Capture ToolCapture(const PatternScheme& s, const fs::path& dir, double noise_dn) {
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

// The same for patterns that vary across the fringes too (markers): camera pixel (x, y) sees
// the plane's projector coordinate u = u0 + (u1 - u0) x / (W - 1) + 0.02 y along the phase and
// a = a0 + (a1 - a0) y / (H - 1) across it, the 8-bit image sampled bilinearly there.
inline Capture ToolCapture2D(const PatternScheme& s, const fs::path& dir, double noise_dn,
                             cv::Size size, double u0, double u1, double a0, double a1,
                             uint32_t seed = 7) {
  Capture cap;
  cap.truth.create(size, CV_32F);
  const auto patterns = GeneratePatterns(s);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_dn);
  fs::create_directories(dir);
  const auto names = s.ImageNames();
  const bool vertical = s.direction == FringeDirection::kVertical;
  for (int r = 0; r < size.height; ++r) {
    for (int c = 0; c < size.width; ++c) {
      cap.truth.at<float>(r, c) =
          static_cast<float>(u0 + (u1 - u0) * c / (size.width - 1.0) + 0.02 * r);
    }
  }
  for (size_t i = 0; i < patterns.size(); ++i) {
    cv::Mat img(size, CV_8U);
    for (int r = 0; r < size.height; ++r) {
      const double a = a0 + (a1 - a0) * r / (size.height - 1.0);
      for (int c = 0; c < size.width; ++c) {
        const double u = cap.truth.at<float>(r, c);
        const int iu = static_cast<int>(std::floor(u)), ia = static_cast<int>(std::floor(a));
        const double tu = u - iu, ta = a - ia;
        auto at = [&](int uu, int aa) {
          return static_cast<double>(vertical ? patterns[i].at<uint8_t>(aa, uu)
                                              : patterns[i].at<uint8_t>(uu, aa));
        };
        const double p = ((1 - tu) * (1 - ta) * at(iu, ia) + tu * (1 - ta) * at(iu + 1, ia) +
                          (1 - tu) * ta * at(iu, ia + 1) + tu * ta * at(iu + 1, ia + 1)) /
                         255.0;
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
inline std::pair<double, double> Errors(const DecodeResult& r, const cv::Mat& truth) {
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

}  // namespace fringe::phase::tool_test
