// Temporal unwrapping methods (issue 27 item 1): hierarchical and number-theoretic beside
// today's heterodyne and Gray code, chosen by the manifest's "unwrapping".
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "fringe/phase/decode.h"
#include "fringe/phase/synthetic.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"

namespace fringe::phase {
namespace {

using test::ErrorOf;

constexpr double kOrderErrorFraction = 0.25;  // |u - truth| above a quarter period = wrong order
constexpr double kStackGainMin = 0.9;         // measured RMS / whole-stack prediction, lower bound
constexpr double kStackGainMax = 1.15;        // and upper bound (8-bit quantisation adds a little)
const cv::Size kSize(320, 200);
// Pixels this many sigma of the coarsest position from the projector's edges may wrap when the
// coarsest period equals the span.
constexpr double kEdgeSigmas = 6.0;

PatternScheme Sets(const std::vector<double>& periods, int steps, Unwrapping method) {
  PatternScheme s;
  s.projector_width = 1280;
  s.projector_height = 800;
  for (const double p : periods) {
    PhaseShiftSet set;
    set.period_px = p;
    set.steps = steps;
    s.phase_sets.push_back(set);
  }
  s.unwrapping = method;
  return s;
}

// SLStudio's PhaseShift2x3 (src/codec/CodecPhaseShift2x3.cpp): 3 steps of
// 0.5 + 0.5 cos(2 pi u / pitch - 2 pi k / 3) at pitch = screenCols / 16, then 3 at pitch =
// screenCols (the phase cue). In fringe's convention cos(2 pi (u + 0.5) / P + offset + shift_k):
// shift_k = -2 pi k / 3 and offset = -pi / P.
PatternScheme SlStudio2x3(int cols) {
  PatternScheme s = Sets({cols / 16.0, static_cast<double>(cols)}, 3, Unwrapping::kAuto);
  s.projector_width = cols;
  for (auto& set : s.phase_sets) {
    set.shifts_rad = {0.0, -2 * M_PI / 3, -4 * M_PI / 3};
    set.phase_offset_rad = -M_PI / set.period_px;
  }
  return s;
}

struct Outcome {
  int64_t valid = 0, wrong = 0;
  double wrong_max_edge_px = 0;  // largest distance of a wrong pixel from the projector's edges
  double rms_px = 0;
  double lo = 0, hi = 0;
};

Outcome DecodeAndCompare(const PatternScheme& s, double b_dn, double sigma_dn, uint64_t seed = 1) {
  const cv::Mat u = LinearProjectorMap(s, kSize);
  SyntheticStackOptions so;
  so.modulation_dn = b_dn;
  so.noise_sigma_dn = sigma_dn;
  so.seed = seed;
  DecodeOptions opt;
  opt.spatial_check_fraction = 0;  // raw unwrapping errors
  opt.noise_sigma_dn = std::max(sigma_dn, 0.5);
  opt.min_modulation_dn = 1;  // every pixel: the orders are what is tested
  const DecodeResult r = Decode(s, RenderSyntheticStack(s, u, so), opt);
  Outcome o;
  double sum = 0;
  o.lo = 1e9;
  o.hi = -1e9;
  for (int y = 0; y < u.rows; ++y) {
    for (int x = 0; x < u.cols; ++x) {
      if (!r.mask.at<uint8_t>(y, x)) continue;
      const double d = r.absolute_phase.at<float>(y, x) - u.at<float>(y, x);
      ++o.valid;
      if (std::fabs(d) > kOrderErrorFraction * s.phase_sets[0].period_px) {
        ++o.wrong;
        const double ut = u.at<float>(y, x);
        o.wrong_max_edge_px = std::max(o.wrong_max_edge_px, std::min(ut, s.Span() - ut));
      } else {
        sum += d * d;
      }
      o.lo = std::min<double>(o.lo, r.absolute_phase.at<float>(y, x));
      o.hi = std::max<double>(o.hi, r.absolute_phase.at<float>(y, x));
    }
  }
  o.rms_px = std::sqrt(sum / std::max<int64_t>(o.valid - o.wrong, 1));
  return o;
}

TEST(Unwrapping, SlStudioPhaseShift2x3DecodesOverTheFullWidth) {
  // Not heterodyne (a beat of 1280/16 and 1280 is 85 px): picked as hierarchical by itself.
  const PatternScheme s = SlStudio2x3(1280);
  EXPECT_FALSE(s.HeterodyneMisfit().empty());
  EXPECT_EQ(s.Method(), Unwrapping::kHierarchical);
  s.Check();
  // Predicted order error at B = 60, sigma = 2: the 1-period set must place u within half of
  // 80 px; its sigma is 1280 / (2 pi) * sqrt(2/3) * 2/60 = 5.5 px, margin 40 px (7 sigma).
  const double top_sigma_px = 1280 / (2 * M_PI) * std::sqrt(2.0 / 3.0) * 2 / 60;
  EXPECT_LT(OrderErrorProbability(s, 2, 60), 1e-9);
  const Outcome o = DecodeAndCompare(s, 60, 2);
  // A single period equal to the span wraps at the projector's edges: pixels there within a
  // few sigma of the coarse position may take the neighbouring representative (SLStudio's own
  // decoder has the same limit). None inside.
  EXPECT_LE(o.wrong_max_edge_px, kEdgeSigmas * top_sigma_px);
  EXPECT_LT(o.wrong, kSize.height * 4);
  EXPECT_EQ(o.valid, kSize.area());
  EXPECT_LT(o.lo, 2.0);
  EXPECT_GT(o.hi, 1277.0);
  // Whole stack: both sets' estimates, by inverse variance.
  const double predicted = AbsolutePhaseSigmaPx(s, 2, 60);
  EXPECT_GT(o.rms_px / predicted, kStackGainMin) << o.rms_px << " vs " << predicted;
  EXPECT_LT(o.rms_px / predicted, kStackGainMax) << o.rms_px << " vs " << predicted;
}

TEST(Unwrapping, HierarchicalWithAnyRatios) {
  for (const std::vector<double>& periods :
       {std::vector<double>{1280.0 / 64, 1280.0 / 8, 1280.0}, std::vector<double>{20.0, 1300.0},
        std::vector<double>{1280.0 / 48, 1280.0 / 6, 1400.0}}) {
    const PatternScheme s = Sets(periods, 4, Unwrapping::kHierarchical);
    s.Check();
    const Outcome o = DecodeAndCompare(s, 100, 1);
    // Coarsest sigma: P / (2 pi) sqrt(1/2) / 100; wrong orders only where it wraps at the edges.
    const double top_sigma_px = periods.back() / (2 * M_PI) * std::sqrt(0.5) / 100;
    EXPECT_LE(o.wrong_max_edge_px, kEdgeSigmas * top_sigma_px) << periods.size();
    if (periods.back() > 1280 * 1.01) {
      EXPECT_EQ(o.wrong, 0) << periods.size();
    }
    EXPECT_EQ(o.valid, kSize.area());
  }
  // 20 px unwrapped straight from one 1300 px period is out of its reach at sigma 8: the noise
  // model says so, and the decoder then gets orders wrong.
  const PatternScheme far = Sets({20.0, 1300.0}, 4, Unwrapping::kHierarchical);
  EXPECT_GT(OrderErrorProbability(far, 8, 60), 1e-3);
  EXPECT_GT(DecodeAndCompare(far, 60, 8).wrong, 0);
}

TEST(Unwrapping, NumberTheoreticCoPrimeCounts) {
  // Two sets: 37 and 32 periods over the span; three sets: 70, 64, 59 (the heterodyne preset's
  // counts over 1.25 x span) decoded number-theoretically.
  const PatternScheme two = Sets({1280.0 / 37, 1280.0 / 32}, 4, Unwrapping::kNumberTheoretic);
  const NumberTheoreticTable t = MakeNumberTheoreticTable(two);
  EXPECT_NEAR(t.length_px, 1280, 1e-6);
  EXPECT_EQ(t.counts, (std::vector<int>{37, 32}));
  const PatternScheme three =
      Sets({1600.0 / 70, 1600.0 / 64, 1600.0 / 59}, 4, Unwrapping::kNumberTheoretic);
  EXPECT_EQ(MakeNumberTheoreticTable(three).counts, (std::vector<int>{70, 64, 59}));
  for (const PatternScheme* s : {&two, &three}) {
    s->Check();
    const Outcome o = DecodeAndCompare(*s, 100, 0.5);
    EXPECT_EQ(o.wrong, 0) << s->phase_sets.size();
    // L = span: a pixel at the very edge may have a key of no position (rejected, not wrong).
    EXPECT_GE(o.valid, kSize.area() - kSize.height);
    EXPECT_LT(o.lo, 2.0);
    EXPECT_GT(o.hi, 1277.0);
  }
  // The table has an entry for every key a position of [0, L) gives: the oracle is the
  // brute-force position search over the same counts.
  for (int i = 0; i < 2000; ++i) {
    const double x = (i + 0.37) / 2000.0;  // fraction of L
    const int k0 = static_cast<int>(std::floor(x * 37)), k1 = static_cast<int>(std::floor(x * 32));
    const int key = 32 * k0 - 37 * k1;
    EXPECT_EQ(t.Lookup(&key), k0) << x;
  }
}

TEST(Unwrapping, AMethodThatDoesNotFitTheSetsNamesTheField) {
  const auto err = [](const PatternScheme& s) { return ErrorOf([&] { s.Check(); }); };
  // Hierarchical whose coarsest set does not cover the span.
  std::string e = err(Sets({20.0, 160.0}, 4, Unwrapping::kHierarchical));
  EXPECT_NE(e.find("PatternScheme.unwrapping = \"hierarchical\": the coarsest set (phase_sets[1]."
                   "period_px = 160) must cover the projector span of 1280 px"),
            std::string::npos)
      << e;
  e = err(Sets({160.0, 1280.0, 20.0}, 4, Unwrapping::kHierarchical));
  EXPECT_NE(e.find("periods must increase from set to set (phase_sets[2].period_px = 20"),
            std::string::npos)
      << e;
  // Counts with a common factor: 32 and 16 periods repeat every 80 px.
  e = err(Sets({40.0, 80.0}, 4, Unwrapping::kNumberTheoretic));
  EXPECT_NE(
      e.find("PatternScheme.unwrapping = \"number-theoretic\": the common length 80 px (fringe "
             "counts 2, 1) is shorter than the projector span"),
      std::string::npos)
      << e;
  e = err(Sets({40.0, 80.0, 90.0, 100.0}, 4, Unwrapping::kNumberTheoretic));
  EXPECT_NE(e.find("needs two or three phase sets"), std::string::npos) << e;
  // Heterodyne named for the SLStudio sets; Gray code named without Gray images.
  e = err(Sets({80.0, 1280.0}, 3, Unwrapping::kHeterodyne));
  EXPECT_NE(e.find("PatternScheme.unwrapping = \"heterodyne\": the coarsest (beat) period 85.33"),
            std::string::npos)
      << e;
  e = err(Sets({40.0}, 4, Unwrapping::kGray));
  EXPECT_NE(e.find("PatternScheme.unwrapping = \"gray\": needs Gray code"), std::string::npos) << e;
  PatternScheme g = Sets({40.0, 1280.0}, 4, Unwrapping::kHierarchical);
  g.gray_bits = 5;
  e = err(g);
  EXPECT_NE(e.find("does not use Gray code, but gray_code.bits = 5"), std::string::npos) << e;
}

TEST(Unwrapping, ManifestFieldRoundTripsAndUnknownNamesAreErrors) {
  const PatternScheme s = Sets({1280.0 / 37, 1280.0 / 32}, 4, Unwrapping::kNumberTheoretic);
  nlohmann::json j = SchemeToJson(s);
  EXPECT_EQ(j["unwrapping"], "number-theoretic");
  EXPECT_EQ(SchemeFromJson(j, "m.json").unwrapping, Unwrapping::kNumberTheoretic);
  // Manifests without the field keep today's meaning.
  EXPECT_FALSE(SchemeToJson(MakeScheme("heterodyne-4x3")).contains("unwrapping"));
  j["unwrapping"] = "temporal";
  const std::string e = ErrorOf([&] { SchemeFromJson(j, "m.json"); });
  EXPECT_NE(e.find("m.json.unwrapping: \"temporal\": expected \"heterodyne\""), std::string::npos)
      << e;
  j["unwrapping"] = "hierarchical";
  j["phase_sets"][1]["period_px"] = 100;
  EXPECT_NE(ErrorOf([&] {
              SchemeFromJson(j, "m.json");
            }).find("unwrapping = \"hierarchical\": the coarsest set"),
            std::string::npos);
}

}  // namespace
}  // namespace fringe::phase
