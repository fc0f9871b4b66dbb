#include "fringe/phase/pattern_scheme.h"

#include <gtest/gtest.h>

#include <cmath>

#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"

namespace fringe::phase {
namespace {

TEST(PatternScheme, PresetsAreValidAndHaveTheDocumentedImageCounts) {
  EXPECT_EQ(MakeScheme("heterodyne-4x3").NumImages(), 12);
  EXPECT_EQ(MakeScheme("thesis-4+3+3").NumImages(), 10);
  EXPECT_EQ(MakeScheme("heterodyne-3x3").NumImages(), 9);
  const PatternScheme g = MakeScheme("gray+4");
  EXPECT_EQ(g.NumImages(), 4 + g.gray_bits + 1);
  EXPECT_EQ(MakeScheme("slsdk-phasegray").NumImages(), 10);
  for (const auto& name : SchemePresetNames()) {
    EXPECT_NO_THROW(MakeScheme(name, 1920, 1080).Check()) << name;
    EXPECT_NO_THROW(MakeScheme(name, 640, 480).Check()) << name;
  }
  EXPECT_THROW(MakeScheme("nonsense"), Error);
}

TEST(PatternScheme, HeterodyneBeatOfBeatsCoversTheProjector) {
  const PatternScheme s = MakeScheme("heterodyne-4x3", 1280, 800);
  const double p1 = s.phase_sets[0].period_px, p2 = s.phase_sets[1].period_px,
               p3 = s.phase_sets[2].period_px;
  const double p12 = p1 * p2 / (p2 - p1), p23 = p2 * p3 / (p3 - p2);
  const double p123 = p12 * p23 / (p23 - p12);
  EXPECT_GT(p123, 1280.0);
  EXPECT_LT(p123, 1.5 * 1280.0);
}

TEST(PatternScheme, BadSchemesAreRejectedNamingTheField) {
  PatternScheme s = MakeScheme("heterodyne-4x3");
  s.phase_sets[1].steps = 2;
  try {
    s.Check();
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("phase_sets[1].steps"), std::string::npos) << e.what();
  }
  s = MakeScheme("heterodyne-4x3");
  std::swap(s.phase_sets[0], s.phase_sets[2]);
  EXPECT_THROW(s.Check(), Error);
  s = MakeScheme("gray+4");
  s.gray_bits -= 1;  // too few periods counted
  EXPECT_THROW(s.Check(), Error);
  s = MakeScheme("gray+4");
  s.phase_sets[0].shifts_rad = {0.0, 0.0, 0.0, 0.0};
  EXPECT_THROW(s.Check(), Error);
}

TEST(PatternScheme, JsonRoundTrip) {
  PatternScheme s = MakeScheme("thesis-4+3+3", 1024, 768);
  s.direction = FringeDirection::kHorizontal;
  s.white_frame = true;
  const PatternScheme r = SchemeFromJson(SchemeToJson(s), "test");
  EXPECT_EQ(r.NumImages(), s.NumImages());
  EXPECT_EQ(r.direction, FringeDirection::kHorizontal);
  ASSERT_EQ(r.phase_sets.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_DOUBLE_EQ(r.phase_sets[i].period_px, s.phase_sets[i].period_px);
    EXPECT_EQ(r.phase_sets[i].steps, s.phase_sets[i].steps);
  }
  test::TempDir dir;
  WriteScheme(dir / "m.json", s);
  EXPECT_EQ(ReadScheme(dir / "m.json").NumImages(), s.NumImages());
  nlohmann::json bad = SchemeToJson(s);
  bad["phase_sets"][0]["steps"] = 2;
  try {
    SchemeFromJson(bad, "bad.json");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("bad.json", 0), 0u) << e.what();
  }
}

TEST(PatternScheme, PatternsFollowTheDocumentedConvention) {
  const PatternScheme s = MakeScheme("gray+4", 1280, 800);
  const auto images = GeneratePatterns(s);
  ASSERT_EQ(static_cast<int>(images.size()), s.NumImages());
  const double p = s.phase_sets[0].period_px;
  for (const auto& img : images) {
    EXPECT_EQ(img.type(), CV_8UC1);
    EXPECT_EQ(img.size(), cv::Size(1280, 800));
  }
  // Phase images: I_k = 0.5 + 0.5 cos(2 pi (u + 0.5) / P + 2 pi k / 4), quantised to 8 bits.
  for (int k = 0; k < 4; ++k) {
    for (int u = 0; u < 1280; u += 37) {
      const double expected = 255 * (0.5 + 0.5 * std::cos(2 * M_PI * (u + 0.5) / p + M_PI_2 * k));
      EXPECT_NEAR(images[k].at<uint8_t>(400, u), expected, 0.5 + 1e-9);
    }
  }
  // Gray code: decoding the bits of a column gives floor((u + 0.5) / P); the complementary
  // bit splits each period in two halves.
  for (int u = 0; u < 1280; ++u) {
    unsigned g = 0;
    for (int b = 0; b <= s.gray_bits; ++b) {
      g = (g << 1) | (images[s.GrayImageIndex(b)].at<uint8_t>(7, u) > 127 ? 1u : 0u);
    }
    unsigned bin = 0;
    for (unsigned x = g; x; x >>= 1) bin ^= x;
    EXPECT_EQ(static_cast<int>(bin), static_cast<int>(std::floor(2 * (u + 0.5) / p))) << u;
  }
}

TEST(PatternScheme, GammaPrecompensationInvertsThePowerLaw) {
  PatternScheme s = MakeScheme("heterodyne-3x3", 640, 480);
  const auto plain = GeneratePatterns(s, 1.0);
  const auto comp = GeneratePatterns(s, 2.2);
  for (int u = 0; u < 640; u += 13) {
    const double lin = plain[0].at<uint8_t>(0, u) / 255.0;
    const double shown = std::pow(comp[0].at<uint8_t>(0, u) / 255.0, 2.2);
    EXPECT_NEAR(shown, lin, 0.02) << u;
  }
}

TEST(PatternScheme, HorizontalFringesVaryAlongRows) {
  PatternScheme s = MakeScheme("heterodyne-4x3", 640, 480);
  s.direction = FringeDirection::kHorizontal;
  const auto images = GeneratePatterns(s);
  EXPECT_EQ(images[0].at<uint8_t>(10, 0), images[0].at<uint8_t>(10, 600));
  EXPECT_NE(images[0].at<uint8_t>(0, 5), images[0].at<uint8_t>(10, 5));
}

TEST(PatternScheme, WritePatternFolderWritesImagesAndManifest) {
  test::TempDir dir;
  const PatternScheme s = MakeScheme("thesis-4+3+3", 320, 200);
  WritePatternFolder(dir / "p", s, 2.2);
  const PatternScheme r = ReadScheme(dir / "p" / "manifest.json");
  EXPECT_DOUBLE_EQ(r.gamma_precompensation, 2.2);
  for (const auto& n : r.ImageNames()) EXPECT_TRUE(std::filesystem::exists(dir / "p" / n)) << n;
}

}  // namespace
}  // namespace fringe::phase
