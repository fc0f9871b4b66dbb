#include "fringe/phase/scheme_presets.h"

#include <gtest/gtest.h>

#include <cmath>

#include "fringe/util/error.h"

namespace fringe::phase {
namespace {

TEST(SchemePresets, GrayFamilyTakesTheCapturesParameters) {
  SchemeParameters p;
  p.projector_width = 912;
  p.projector_height = 1140;
  p.period_px = 19;
  p.steps = 6;
  p.phase_offset_rad = -M_PI;
  p.image_names = "img_%02d.bmp";
  const PatternScheme s = MakePresetScheme("gray+6", p);
  EXPECT_EQ(s.projector_width, 912);
  ASSERT_EQ(s.phase_sets.size(), 1u);
  EXPECT_DOUBLE_EQ(s.phase_sets[0].period_px, 19);
  EXPECT_EQ(s.phase_sets[0].steps, 6);
  EXPECT_DOUBLE_EQ(s.phase_sets[0].phase_offset_rad, -M_PI);
  // The fewest bits whose periods cover 912 px: 2^6 * 19 = 1216 >= 912 > 2^5 * 19.
  EXPECT_EQ(s.gray_bits, 6);
  EXPECT_TRUE(s.gray_complementary);
  ASSERT_EQ(s.NumImages(), 6 + 6 + 1);
  EXPECT_EQ(s.ImageNames()[0], "img_00.bmp");
  EXPECT_EQ(s.ImageNames()[12], "img_12.bmp");
}

TEST(SchemePresets, SlsdkIsAnAliasOfGray4WithItsValues) {
  const PatternScheme alias = MakePresetScheme("slsdk-phasegray", {});
  const PatternScheme old = MakeScheme("slsdk-phasegray");
  EXPECT_EQ(alias.projector_width, old.projector_width);
  EXPECT_EQ(alias.gray_bits, old.gray_bits);
  EXPECT_DOUBLE_EQ(alias.phase_sets[0].period_px, old.phase_sets[0].period_px);
  EXPECT_DOUBLE_EQ(alias.phase_sets[0].phase_offset_rad, old.phase_sets[0].phase_offset_rad);
  EXPECT_EQ(alias.ImageNames(), old.ImageNames());
  SchemeParameters p;
  p.image_names = "a.png,b.png,c.png,d.png,e.png,f.png,g.png,h.png,i.png,j.png";
  EXPECT_EQ(MakePresetScheme("slsdk-phasegray", p).ImageNames()[9], "j.png");
}

TEST(SchemePresets, HeterodyneCountsOverTheSpan) {
  SchemeParameters p;
  p.projector_width = 1280;
  // Beats of 6 and 5.5 fringes, beat of beats 0.5 fringe: its period (2560 px) covers the span.
  p.counts = {60, 54, 48.5};
  const PatternScheme s = MakePresetScheme("heterodyne-4x3", p);
  EXPECT_DOUBLE_EQ(s.phase_sets[0].period_px, 1280.0 / 60);
  EXPECT_DOUBLE_EQ(s.phase_sets[2].period_px, 1280.0 / 48.5);
  p.counts = {70, 64};
  EXPECT_THROW(MakePresetScheme("heterodyne-4x3", p), Error);
}

TEST(SchemePresets, BadParametersAndNamesAreErrors) {
  SchemeParameters p;
  p.image_names = "../%d.png";
  EXPECT_THROW(MakePresetScheme("gray+4", p), Error);
  p.image_names = "%s.png";
  EXPECT_THROW(MakePresetScheme("gray+4", p), Error);
  p = {};
  p.steps = 2;
  EXPECT_THROW(MakePresetScheme("gray+4", p), Error);
  p = {};
  p.period_px = 20;
  try {
    SchemeFromArgument("/no/such/manifest.json", p);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("apply to presets"), std::string::npos) << e.what();
  }
  EXPECT_THROW(SchemeFromArgument("gray+x", {}), Error);
}

}  // namespace
}  // namespace fringe::phase
