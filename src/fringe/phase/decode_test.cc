#include "fringe/phase/decode.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <iostream>
#include <opencv2/imgproc.hpp>

#include "fringe/io/image_io.h"
#include "fringe/phase/gamma.h"
#include "fringe/phase/synthetic.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"

namespace fringe::phase {
namespace {

// Named tolerances.
constexpr double kCrbRatioMax = 1.05;           // issue 4: RMS / noise limit for Gaussian noise
constexpr double kCrbRatioMin = 0.95;           // and not suspiciously below it
constexpr double kNoiseFreeErrorPx = 0.01;      // 16-bit, no noise: float arithmetic only
constexpr double kOrderErrorFractionPx = 0.25;  // |u - truth| above a quarter period = wrong order

const cv::Size kSize(320, 256);

double WrapPi(double x) { return x - 2 * M_PI * std::round(x / (2 * M_PI)); }

struct Errors {
  double wrapped_rms_rad = 0;
  double abs_rms_px = 0;
  int64_t wrong_orders = 0;
  int64_t valid = 0;
};

Errors Compare(const PatternScheme& s, const DecodeResult& r, const cv::Mat& u_true) {
  Errors e;
  const auto& set = s.phase_sets[0];
  double sw = 0, sa = 0;
  for (int y = 0; y < u_true.rows; ++y) {
    for (int x = 0; x < u_true.cols; ++x) {
      if (!r.mask.at<uint8_t>(y, x)) continue;
      const double u = u_true.at<float>(y, x);
      const double psi = 2 * M_PI * (u + 0.5) / set.period_px + set.phase_offset_rad;
      const double dw = WrapPi(r.wrapped_phase.at<float>(y, x) - psi);
      const double da = r.absolute_phase.at<float>(y, x) - u;
      sw += dw * dw;
      ++e.valid;
      if (std::fabs(da) > kOrderErrorFractionPx * set.period_px) {
        ++e.wrong_orders;
      } else {
        sa += da * da;
      }
    }
  }
  e.wrapped_rms_rad = std::sqrt(sw / std::max<int64_t>(e.valid, 1));
  e.abs_rms_px = std::sqrt(sa / std::max<int64_t>(e.valid - e.wrong_orders, 1));
  return e;
}

TEST(Decode, DefaultOptionsPassCheck) {
  EXPECT_NO_THROW(DecodeOptions().Check());
  EXPECT_NO_THROW(GammaEstimateOptions().Check());
  EXPECT_NO_THROW(SyntheticStackOptions().Check());
  DecodeOptions o;
  o.max_order_residual = 0.7;
  EXPECT_THROW(o.Check(), Error);
}

TEST(Decode, NoiseFreeSixteenBitRecoversProjectorCoordinate) {
  for (const std::string name : {"heterodyne-4x3", "thesis-4+3+3", "heterodyne-3x3", "gray+4"}) {
    const PatternScheme s = MakeScheme(name, 1280, 800);
    const cv::Mat u = LinearProjectorMap(s, kSize);
    SyntheticStackOptions so;
    so.bit_depth = 16;
    so.background_dn = 30000;
    so.modulation_dn = 20000;
    so.noise_sigma_dn = 0;
    so.quantize_patterns = false;
    const DecodeResult r = Decode(s, RenderSyntheticStack(s, u, so));
    const Errors e = Compare(s, r, u);
    EXPECT_EQ(e.valid, kSize.area()) << name << ": " << r.summary.BriefReport();
    EXPECT_EQ(e.wrong_orders, 0) << name;
    EXPECT_LT(e.abs_rms_px, kNoiseFreeErrorPx) << name;
    EXPECT_NEAR(cv::mean(r.modulation)[0], so.modulation_dn, 1.0) << name;
    EXPECT_NEAR(cv::mean(r.background)[0], so.background_dn, 1.0) << name;
  }
}

TEST(Decode, WrappedPhaseNoiseIsAtTheNoiseLimit) {
  // sigma_phi = sqrt(2/N) sigma / B; 8-bit rounding adds 1/12 DN^2 to the noise variance.
  const double sigma = 2.0, b = 60.0;
  for (const std::string name : {"heterodyne-3x3", "heterodyne-4x3", "thesis-4+3+3"}) {
    const PatternScheme s = MakeScheme(name, 1280, 800);
    const cv::Mat u = LinearProjectorMap(s, kSize);
    SyntheticStackOptions so;
    so.modulation_dn = b;
    so.noise_sigma_dn = sigma;
    so.quantize_patterns = false;
    const DecodeResult r = Decode(s, RenderSyntheticStack(s, u, so));
    const Errors e = Compare(s, r, u);
    const int n = s.phase_sets[0].steps;
    const double limit = std::sqrt(2.0 / n) * std::sqrt(sigma * sigma + 1.0 / 12) / b;
    EXPECT_NEAR(WrappedPhaseSigma(s, 0, 1.0, 1.0), std::sqrt(2.0 / n), 1e-9);
    EXPECT_LT(e.wrapped_rms_rad / limit, kCrbRatioMax) << name;
    EXPECT_GT(e.wrapped_rms_rad / limit, kCrbRatioMin) << name;
    EXPECT_EQ(e.wrong_orders, 0) << name;
    EXPECT_GT(r.summary.ValidFraction(), 0.999) << name << ": " << r.summary.BriefReport();
  }
}

TEST(Decode, ModulationThresholdFollowsTheNoiseAnalysis) {
  const PatternScheme s = MakeScheme("heterodyne-4x3");
  // Issue 4: a wrong order becomes likely below B ~ 30-40 DN at sigma ~ 2 DN.
  const double b = ModulationThreshold(s, 2.0, 1e-6);
  EXPECT_GT(b, 25.0);
  EXPECT_LT(b, 40.0);
  EXPECT_NEAR(OrderErrorProbability(s, 2.0, b), 1e-6, 1e-7);
  EXPECT_LT(OrderErrorProbability(s, 2.0, 40.0), 1e-7);
  EXPECT_NEAR(ModulationThreshold(s, 4.0, 1e-6), 2 * b, 1e-6 * b);
  // Fewer steps on the coarse sets -> more noise -> higher threshold.
  EXPECT_GT(ModulationThreshold(MakeScheme("thesis-4+3+3"), 2.0, 1e-6), b);
}

TEST(Decode, HeterodyneOrdersAreCorrectOverTheFullWidthNearTheThreshold) {
  // At B = 40 DN, sigma = 2 DN the predicted wrong-order rate is < 1e-7 per pixel: none of
  // the 82k pixels may be wrong.
  for (const std::string name : {"heterodyne-4x3", "thesis-4+3+3"}) {
    const PatternScheme s = MakeScheme(name, 1280, 800);
    const cv::Mat u = LinearProjectorMap(s, kSize);
    SyntheticStackOptions so;
    so.modulation_dn = 40;
    so.noise_sigma_dn = 2;
    DecodeOptions opt;
    opt.spatial_check_fraction = 0;  // count raw unwrapping errors
    opt.noise_sigma_dn = 2;          // the threshold of the noise model at the true sigma
    const DecodeResult r = Decode(s, RenderSyntheticStack(s, u, so), opt);
    const Errors e = Compare(s, r, u);
    EXPECT_EQ(e.wrong_orders, 0) << name;
    // Estimated B scatters around 40 with sigma ~1.4 DN; the threshold is ~33-38 DN.
    EXPECT_GT(r.summary.ValidFraction(), 0.9) << name << ": " << r.summary.BriefReport();
    double lo, hi;
    cv::minMaxLoc(r.absolute_phase, &lo, &hi, nullptr, nullptr, r.mask);
    EXPECT_LT(lo, 1.0);
    EXPECT_GT(hi, 1278.0);
  }
}

TEST(Decode, GrayCodeHasNoPeriodEdgeJumps) {
  const PatternScheme s = MakeScheme("gray+4", 1280, 800);
  const cv::Mat u = LinearProjectorMap(s, kSize);
  SyntheticStackOptions so;
  so.modulation_dn = 50;
  so.noise_sigma_dn = 2;
  DecodeOptions opt;
  opt.spatial_check_fraction = 0;
  const DecodeResult r = Decode(s, RenderSyntheticStack(s, u, so), opt);
  const Errors e = Compare(s, r, u);
  EXPECT_EQ(e.wrong_orders, 0);
  EXPECT_GT(r.summary.ValidFraction(), 0.999) << r.summary.BriefReport();
  EXPECT_EQ(JumpFraction(r.absolute_phase, r.mask, s.phase_sets[0].period_px), 0.0);
}

TEST(Decode, PlainGrayCodeEdgeErrorsAreRepairedByTheSpatialCheck) {
  PatternScheme s = MakeScheme("gray+4", 1280, 800);
  s.gray_complementary = false;
  const cv::Mat u = LinearProjectorMap(s, kSize);
  SyntheticStackOptions so;
  so.modulation_dn = 50;
  so.noise_sigma_dn = 2;
  const auto images = RenderSyntheticStack(s, u, so);
  DecodeOptions raw;
  raw.spatial_check_fraction = 0;
  const Errors before = Compare(s, Decode(s, images, raw), u);
  const DecodeResult r = Decode(s, images);
  const Errors after = Compare(s, r, u);
  std::cout << "plain Gray code: " << before.wrong_orders
            << " edge errors before the spatial check, " << after.wrong_orders << " after; "
            << r.summary.BriefReport() << "\n";
  EXPECT_GT(before.wrong_orders, 0);  // plain Gray code does jump at period edges
  EXPECT_EQ(after.wrong_orders, 0);   // isolated edge errors are whole periods: repaired
  EXPECT_GT(r.summary.ValidFraction(), 0.99);
}

TEST(Decode, HorizontalFringesGiveProjectorRows) {
  PatternScheme s = MakeScheme("thesis-4+3+3", 1280, 800);
  s.direction = FringeDirection::kHorizontal;
  s.phase_sets = MakeScheme("thesis-4+3+3", 800, 800).phase_sets;  // periods for an 800 span
  const cv::Mat u = LinearProjectorMap(s, kSize);
  SyntheticStackOptions so;
  so.noise_sigma_dn = 1;
  const DecodeResult r = Decode(s, RenderSyntheticStack(s, u, so));
  const Errors e = Compare(s, r, u);
  EXPECT_EQ(e.wrong_orders, 0);
  EXPECT_GT(r.summary.ValidFraction(), 0.999);
}

TEST(Decode, QualityMaskRejectsSaturatedDarkAndFlatPixels) {
  const PatternScheme s = MakeScheme("heterodyne-4x3", 1280, 800);
  const cv::Mat u = LinearProjectorMap(s, kSize);
  SyntheticStackOptions so;
  auto images = RenderSyntheticStack(s, u, so);
  const cv::Rect sat(10, 10, 20, 20), dark(50, 10, 20, 20), flat(90, 10, 20, 20);
  for (auto& im : images) {
    im(sat).setTo(255);
    im(dark).setTo(1);
    im(flat).setTo(120);  // no fringe contrast: shadow or a surface the projector misses
  }
  const DecodeResult r = Decode(s, images);
  EXPECT_EQ(r.summary.rejected_saturated, sat.area());
  EXPECT_EQ(r.summary.rejected_underexposed, dark.area());
  EXPECT_EQ(r.summary.rejected_low_modulation, flat.area());
  EXPECT_EQ(cv::countNonZero(r.mask(sat)), 0);
  EXPECT_TRUE(std::isnan(r.absolute_phase.at<float>(15, 95)));
  EXPECT_EQ(r.summary.valid + r.summary.rejected_saturated + r.summary.rejected_underexposed +
                r.summary.rejected_low_modulation + r.summary.rejected_shadow +
                r.summary.rejected_order_ambiguous + r.summary.rejected_spatial,
            r.summary.pixels);
}

TEST(Decode, TwelveBitDataInSixteenBitImagesUsesTheGivenFullScale) {
  const PatternScheme s = MakeScheme("thesis-4+3+3", 1280, 800);
  const cv::Mat u = LinearProjectorMap(s, cv::Size(160, 128));
  SyntheticStackOptions so;
  so.bit_depth = 16;
  so.background_dn = 2000;
  so.modulation_dn = 1500;
  so.noise_sigma_dn = 8;
  auto images = RenderSyntheticStack(s, u, so);
  images[0](cv::Rect(0, 0, 10, 10)).setTo(4095);  // saturated for a 12-bit sensor
  DecodeOptions opt;
  opt.full_scale_dn = 4095;
  opt.noise_sigma_dn = 8;
  const DecodeResult r = Decode(s, images, opt);
  EXPECT_EQ(r.summary.rejected_saturated, 100);
  EXPECT_EQ(r.summary.valid, u.total() - 100) << r.summary.BriefReport();
  EXPECT_EQ(Compare(s, r, u).wrong_orders, 0);
}

TEST(Decode, NoiseIsEstimatedFromTheResidualOfAFourStepSet) {
  // Issue 10: gamma-compensated 8-bit images (pattern quantisation and gamma harmonics enter the
  // residual too); the estimate must be within 10 % of the true sigma.
  constexpr double kMaxRelativeError = 0.10;
  for (const std::string name : {"heterodyne-4x3", "thesis-4+3+3"}) {
    for (const double sigma : {1.0, 1.5, 3.0}) {
      const PatternScheme s = MakeScheme(name, 1280, 800);
      const cv::Mat u = LinearProjectorMap(s, kSize);
      SyntheticStackOptions so;
      so.modulation_dn = 90;
      so.noise_sigma_dn = sigma;
      so.projector_gamma = 2.2;
      so.precompensate_gamma = 2.2;
      so.seed = 77;
      const auto images = RenderSyntheticStack(s, u, so);
      const DecodeResult r = Decode(s, images);  // noise_sigma_dn = 0: estimate
      SCOPED_TRACE(name + " sigma " + std::to_string(sigma) + ": " + r.summary.BriefReport());
      EXPECT_EQ(r.summary.noise.source, NoiseSource::kEstimated);
      EXPECT_EQ(r.summary.noise.set, 0);
      EXPECT_NEAR(r.summary.noise.sigma_dn, sigma, kMaxRelativeError * sigma);
      EXPECT_NE(r.summary.BriefReport().find("estimated"), std::string::npos);
      // The threshold follows the estimate.
      EXPECT_NEAR(r.summary.min_modulation_dn,
                  ModulationThreshold(s, r.summary.noise.sigma_dn, 1e-6), 1e-9);
      EXPECT_FALSE(r.summary.threshold_bounded);
    }
  }
}

TEST(Decode, NoiseEstimateIgnoresGammaHarmonicsOfUncompensatedPatterns) {
  // Uncompensated gamma 2.2 puts a second harmonic of ~18 % of the modulation into the 4-step
  // residual (the simulator's default scan: +-9 DN against 1.5 DN of noise); taken as noise it
  // raised the modulation threshold until 95 % of a simulated view was rejected. The fringes run
  // obliquely across the image here, so neither image axis follows them exactly.
  constexpr double kMaxRelativeError = 0.10;
  const PatternScheme s = MakeScheme("heterodyne-4x3", 1280, 800);
  cv::Mat u(kSize, CV_32F);
  for (int y = 0; y < u.rows; ++y) {
    for (int x = 0; x < u.cols; ++x) u.at<float>(y, x) = 200.0f + 0.5f * x + 0.25f * y;
  }
  for (const double sigma : {1.0, 1.5, 3.0}) {
    SyntheticStackOptions so;
    so.modulation_dn = 90;
    so.noise_sigma_dn = sigma;
    so.projector_gamma = 2.2;
    so.seed = 78;
    const DecodeResult r = Decode(s, RenderSyntheticStack(s, u, so));
    SCOPED_TRACE("sigma " + std::to_string(sigma) + ": " + r.summary.BriefReport());
    EXPECT_EQ(r.summary.noise.source, NoiseSource::kEstimated);
    EXPECT_NEAR(r.summary.noise.sigma_dn, sigma, kMaxRelativeError * sigma);
    EXPECT_GT(r.summary.ValidFraction(), 0.99);
  }
}

TEST(Decode, ThreeStepSchemesKeepTheAssumedNoiseAndSaySo) {
  const PatternScheme s = MakeScheme("heterodyne-3x3", 1280, 800);
  const cv::Mat u = LinearProjectorMap(s, kSize);
  const DecodeResult r = Decode(s, RenderSyntheticStack(s, u, SyntheticStackOptions()));
  EXPECT_EQ(r.summary.noise.source, NoiseSource::kAssumed);
  EXPECT_EQ(r.summary.noise.sigma_dn, kAssumedNoiseSigmaDn);
  EXPECT_NE(r.summary.noise.message.find("3-step"), std::string::npos);
  DecodeOptions given;
  given.noise_sigma_dn = 1.25;
  const DecodeResult g = Decode(s, RenderSyntheticStack(s, u, SyntheticStackOptions()), given);
  EXPECT_EQ(g.summary.noise.source, NoiseSource::kGiven);
  EXPECT_EQ(g.summary.noise.sigma_dn, 1.25);
}

TEST(Decode, BeatOfBeatsEqualToTheSpanGivesABoundedThreshold) {
  // Periods 1280/70, 1280/64, 1280/59 on a 1280-px projector: the beat of beats is the span
  // up to rounding. The scheme is accepted and decodes with a finite threshold.
  PatternScheme s = MakeScheme("heterodyne-4x3", 1280, 800);
  const int counts[3] = {70, 64, 59};
  for (int i = 0; i < 3; ++i) s.phase_sets[i].period_px = 1280.0 / counts[i];
  ASSERT_NO_THROW(s.Check());
  const double b_min = ModulationThreshold(s, 2.0, 1e-6);
  EXPECT_LT(b_min, 50.0);
  // Inside the projector (away from its very edges, where the zero margin leaves the order to
  // the checks) almost every pixel decodes with the right order.
  cv::Mat u = LinearProjectorMap(s, kSize);
  u = u * (1200.0 / 1279.0) + 40.0;
  SyntheticStackOptions so;
  so.noise_sigma_dn = 1.5;
  const DecodeResult r = Decode(s, RenderSyntheticStack(s, u, so));
  EXPECT_GT(r.summary.ValidFraction(), 0.99) << r.summary.BriefReport();
  EXPECT_EQ(Compare(s, r, u).wrong_orders, 0);
}

TEST(Decode, AutomaticThresholdIsBoundedAndTheSummarySaysWhy) {
  // A noise so large that the order-error model asks for more modulation than the camera can
  // give: the threshold stops at kMaxModulationThresholdFraction of full scale and the summary
  // says why so many pixels were rejected.
  const PatternScheme s = MakeScheme("heterodyne-4x3", 1280, 800);
  const cv::Mat u = LinearProjectorMap(s, kSize);
  SyntheticStackOptions so;
  so.modulation_dn = 20;
  DecodeOptions opt;
  opt.noise_sigma_dn = 10;  // asks for B > 100 DN
  const DecodeResult r = Decode(s, RenderSyntheticStack(s, u, so), opt);
  EXPECT_TRUE(r.summary.threshold_bounded);
  EXPECT_DOUBLE_EQ(r.summary.min_modulation_dn, kMaxModulationThresholdFraction * 255);
  EXPECT_NE(r.summary.message.find("bounded"), std::string::npos) << r.summary.message;
  EXPECT_NE(r.summary.message.find("modulation below"), std::string::npos) << r.summary.message;
}

TEST(Decode, SaturatedGrayCodeImagesDoNotRejectPixels) {
  // Issue 10: a specular spot saturates the bright Gray-code stripes but not the phase images;
  // the bright decision is unambiguous, so the pixels decode. Saturation in a phase image still
  // rejects.
  const PatternScheme s = MakeScheme("gray+4", 1280, 800);
  const cv::Mat u = LinearProjectorMap(s, kSize);
  SyntheticStackOptions so;
  so.modulation_dn = 80;
  so.noise_sigma_dn = 1;
  auto images = RenderSyntheticStack(s, u, so);
  const cv::Rect spot(100, 100, 40, 30), phase_spot(200, 100, 20, 20);
  for (int i = s.NumPhaseImages(); i < s.NumImages(); ++i) {
    cv::Mat roi = images[i](spot);
    roi.setTo(255, roi > so.background_dn);
  }
  images[1](phase_spot).setTo(255);
  const DecodeResult r = Decode(s, images);
  EXPECT_EQ(r.summary.rejected_saturated, phase_spot.area()) << r.summary.BriefReport();
  EXPECT_EQ(cv::countNonZero(r.mask(spot)), spot.area());
  EXPECT_EQ(Compare(s, r, u).wrong_orders, 0);
}

TEST(Decode, SpatialCheckRepairsWrongOrders) {
  const PatternScheme s = MakeScheme("heterodyne-4x3", 1280, 800);
  const cv::Mat u = LinearProjectorMap(s, kSize);
  SyntheticStackOptions so;
  so.noise_sigma_dn = 1;
  auto images = RenderSyntheticStack(s, u, so);
  // Corrupt the coarsest set of isolated pixels with the values of a pixel ~ 2 beat periods
  // away: their fine phase is right, their fringe order wrong.
  const int first = s.PhaseImageIndex(2);
  std::vector<cv::Point> bad;
  for (int y = 20; y < kSize.height - 20; y += 37) {
    for (int x = 20; x < kSize.width - 120; x += 41) bad.emplace_back(x, y);
  }
  for (const auto& p : bad) {
    for (int k = 0; k < 4; ++k) {
      images[first + k].at<uint8_t>(p) = images[first + k].at<uint8_t>(p.y, p.x + 100);
    }
  }
  DecodeOptions no_check;
  no_check.spatial_check_fraction = 0;
  no_check.max_order_residual = 0.5;
  const Errors before = Compare(s, Decode(s, images, no_check), u);
  EXPECT_GT(before.wrong_orders, static_cast<int64_t>(bad.size()) / 2);
  const DecodeResult r = Decode(s, images);
  const Errors after = Compare(s, r, u);
  EXPECT_EQ(after.wrong_orders, 0);
  EXPECT_GE(
      r.summary.orders_repaired + r.summary.rejected_spatial + r.summary.rejected_order_ambiguous,
      before.wrong_orders);
}

TEST(Decode, ResultDoesNotDependOnThreadCount) {
  const PatternScheme s = MakeScheme("thesis-4+3+3", 1280, 800);
  const cv::Mat u = LinearProjectorMap(s, kSize);
  SyntheticStackOptions so;
  so.modulation_dn = 30;
  so.noise_sigma_dn = 3;
  const auto images = RenderSyntheticStack(s, u, so);
  tbb::task_arena one(1);
  DecodeResult r1;
  one.execute([&] { r1 = Decode(s, images); });
  const DecodeResult r2 = Decode(s, images);
  EXPECT_EQ(cv::norm(r1.mask, r2.mask, cv::NORM_INF), 0.0);
  cv::Mat a1 = r1.absolute_phase.clone(), a2 = r2.absolute_phase.clone();
  a1.setTo(0, r1.mask == 0);
  a2.setTo(0, r2.mask == 0);
  EXPECT_EQ(cv::norm(a1, a2, cv::NORM_INF), 0.0);
  EXPECT_EQ(r1.summary.valid, r2.summary.valid);
}

TEST(Decode, BadStacksAreRejectedNamingTheImage) {
  const PatternScheme s = MakeScheme("heterodyne-4x3", 1280, 800);
  const cv::Mat u = LinearProjectorMap(s, cv::Size(64, 48));
  auto images = RenderSyntheticStack(s, u, SyntheticStackOptions());
  auto fewer = images;
  fewer.pop_back();
  EXPECT_THROW(Decode(s, fewer), Error);
  auto resized = images;
  resized[5] = cv::Mat(47, 64, CV_8U, cv::Scalar(0));
  try {
    Decode(s, resized);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("image 5"), std::string::npos) << e.what();
  }
  auto mixed = images;
  mixed[3].convertTo(mixed[3], CV_16U);
  EXPECT_THROW(Decode(s, mixed), Error);
  auto colour = images;
  cv::cvtColor(colour[0], colour[0], cv::COLOR_GRAY2BGR);
  EXPECT_THROW(Decode(s, colour), Error);
}

// Two exposures of a scene with a bright (specular-like) patch on a dark part: the short
// exposure decodes only the patch (the dark part's modulation is below the threshold), the long
// one only the dark part (the patch saturates); combined, each pixel takes the exposure with the
// highest unsaturated modulation, and every pixel decodes with the right order.
TEST(Decode, TwoExposuresCoverWhatEitherAloneMisses) {
  const PatternScheme s = MakeScheme("heterodyne-4x3", 1280, 800);
  const cv::Mat u = LinearProjectorMap(s, kSize);
  const cv::Rect patch(100, 60, 120, 100);
  constexpr double kGain = 8;  // long / short exposure
  auto render = [&](double gain, uint64_t seed) {
    SyntheticStackOptions dark, bright;
    dark.background_dn = 10 * gain;
    dark.modulation_dn = 6 * gain;
    bright.background_dn = 150 * gain;
    bright.modulation_dn = 100 * gain;
    dark.noise_sigma_dn = bright.noise_sigma_dn = 1.5;
    dark.seed = seed;
    bright.seed = seed + 100;
    std::vector<cv::Mat> images = RenderSyntheticStack(s, u, dark);
    const std::vector<cv::Mat> lit = RenderSyntheticStack(s, u, bright);
    for (size_t i = 0; i < images.size(); ++i) lit[i](patch).copyTo(images[i](patch));
    return images;
  };
  DecodeOptions o;
  o.noise_sigma_dn = 1.5;
  const std::vector<std::vector<cv::Mat>> stacks = {render(1, 1), render(kGain, 2)};
  const DecodeResult short_only = Decode(s, stacks[0], o);
  const DecodeResult long_only = Decode(s, stacks[1], o);
  const DecodeResult both = DecodeExposures(s, stacks, o);
  const int64_t pixels = static_cast<int64_t>(kSize.area());
  std::cout << "short " << short_only.summary.valid << ", long " << long_only.summary.valid
            << ", both " << both.summary.valid << " of " << pixels << "\n"
            << both.summary.BriefReport() << "\n";
  // Each alone misses a large part; together nearly everything decodes.
  EXPECT_LT(short_only.summary.valid, patch.area() + pixels / 100);
  EXPECT_GT(long_only.summary.rejected_saturated, patch.area() / 2);
  EXPECT_GT(both.summary.valid, short_only.summary.valid);
  EXPECT_GT(both.summary.valid, long_only.summary.valid);
  EXPECT_GT(both.summary.valid, pixels * 99 / 100);
  const Errors e = Compare(s, both, u);
  EXPECT_EQ(e.wrong_orders, 0);
  EXPECT_LT(e.abs_rms_px, 0.5);
  // The patch came from the short exposure, the dark part from the long one.
  ASSERT_EQ(both.exposure.type(), CV_8U);
  EXPECT_EQ(both.exposure.at<uint8_t>(patch.y + 50, patch.x + 60), 0);
  EXPECT_EQ(both.exposure.at<uint8_t>(10, 10), 1);
  ASSERT_EQ(both.summary.exposures.size(), 2u);
  EXPECT_EQ(both.summary.exposures[0].chosen + both.summary.exposures[1].chosen,
            both.summary.valid);
  EXPECT_EQ(both.summary.exposures[1].valid, long_only.summary.valid);
  EXPECT_EQ(both.summary.valid + both.summary.rejected_saturated +
                both.summary.rejected_underexposed + both.summary.rejected_low_modulation +
                both.summary.rejected_shadow + both.summary.rejected_order_ambiguous +
                both.summary.rejected_spatial,
            both.summary.pixels);
  // One exposure is exactly Decode; a stack of another size is refused naming the exposure.
  const DecodeResult one = DecodeExposures(s, {stacks[1]}, o);
  EXPECT_EQ(one.summary.valid, long_only.summary.valid);
  EXPECT_TRUE(one.exposure.empty());
  std::vector<cv::Mat> small;
  for (const auto& im : stacks[1]) small.push_back(im(cv::Rect(0, 0, 64, 48)).clone());
  try {
    DecodeExposures(s, {stacks[0], small}, o);
    FAIL();
  } catch (const Error& err) {
    EXPECT_NE(std::string(err.what()).find("exposure 1"), std::string::npos) << err.what();
  }
}

// The exposures' gain is measured where both decode, and the combined background is on the
// main exposure's scale everywhere (no step at the saturated patch taken from the short one).
TEST(Decode, ExposureGainPutsTheMapsOnOneScale) {
  constexpr double kGain = 2;
  // The fitted background of the synthetic stacks deviates from A by a few DN (8-bit patterns);
  // without the gain the step at the patch would be 60 DN.
  constexpr double kBackgroundTolDn = 5;
  const PatternScheme s = MakeScheme("heterodyne-4x3", 1280, 800);
  const cv::Mat u = LinearProjectorMap(s, kSize);
  SyntheticStackOptions dim, bright;
  dim.background_dn = 60;  // B above the threshold (~35 DN at 2 DN of noise): both decode
  dim.modulation_dn = 50;
  bright.background_dn = kGain * 60;  // peaks at 220 DN: unsaturated
  bright.modulation_dn = kGain * 50;
  bright.seed = 2;
  const std::vector<cv::Mat> short_stack = RenderSyntheticStack(s, u, dim);
  std::vector<cv::Mat> long_stack = RenderSyntheticStack(s, u, bright);
  const cv::Rect patch(40, 40, 60, 50);
  for (auto& im : long_stack) im(patch).setTo(255);  // a highlight saturating the long one
  DecodeOptions o;
  o.noise_sigma_dn = 2;
  const DecodeResult both = DecodeExposures(s, {short_stack, long_stack}, o);
  ASSERT_EQ(both.summary.exposures.size(), 2u);
  EXPECT_EQ(both.summary.exposures[1].gain, 1.0);  // the long one supplies most pixels
  EXPECT_NEAR(both.summary.exposures[0].gain, 1 / kGain, 0.01);
  EXPECT_EQ(both.exposure.at<uint8_t>(60, 60), 0);    // patch: short exposure
  EXPECT_EQ(both.exposure.at<uint8_t>(200, 250), 1);  // elsewhere: long exposure
  EXPECT_NEAR(both.background.at<float>(60, 60), kGain * 60, kBackgroundTolDn);
  EXPECT_NEAR(both.background.at<float>(200, 250), kGain * 60, kBackgroundTolDn);
  EXPECT_NEAR(both.modulation.at<float>(60, 60), kGain * 50, kBackgroundTolDn);
  EXPECT_NEAR(both.background.at<float>(60, 60), both.background.at<float>(60, 110),
              kBackgroundTolDn);  // no step across the patch's edge (x 40..99)
  EXPECT_EQ(both.summary.valid, both.summary.pixels);
}

// Repaired fringe orders of a combination count the combination's pixels, each once: the
// scheme-mismatch warning compares them with the combination's valid pixels.
TEST(Decode, ExposuresCountRepairedOrdersOfTheCombinedPixelsOnce) {
  // Plain Gray code (no complementary bit) leaves order errors at period edges that the spatial
  // check repairs, in every exposure.
  PatternScheme s = MakeScheme("gray+4", 1280, 800);
  s.gray_complementary = false;
  const cv::Mat u = LinearProjectorMap(s, kSize);
  SyntheticStackOptions dim, bright;
  dim.modulation_dn = 50;
  bright.modulation_dn = 80;  // higher B everywhere: the combination takes every pixel from it
  dim.noise_sigma_dn = bright.noise_sigma_dn = 2;
  bright.seed = 2;
  const std::vector<cv::Mat> dim_stack = RenderSyntheticStack(s, u, dim);
  const std::vector<cv::Mat> bright_stack = RenderSyntheticStack(s, u, bright);
  const DecodeResult dim_only = Decode(s, dim_stack);
  const DecodeResult bright_only = Decode(s, bright_stack);
  ASSERT_GT(dim_only.summary.orders_repaired, 0);
  ASSERT_GT(bright_only.summary.orders_repaired, 0);
  EXPECT_EQ(static_cast<int64_t>(dim_only.repaired_px.size()), dim_only.summary.orders_repaired);

  const DecodeResult both = DecodeExposures(s, {dim_stack, bright_stack});
  SCOPED_TRACE(both.summary.BriefReport());
  ASSERT_EQ(both.summary.exposures.size(), 2u);
  EXPECT_EQ(both.summary.exposures[1].chosen, both.summary.valid);
  // The bright exposure's repairs, not the sum of both exposures'.
  EXPECT_EQ(both.summary.orders_repaired, bright_only.summary.orders_repaired);
  EXPECT_EQ(both.summary.exposures[0].orders_repaired, dim_only.summary.orders_repaired);
  EXPECT_EQ(both.summary.exposures[1].orders_repaired, bright_only.summary.orders_repaired);
  EXPECT_EQ(Compare(s, both, u).wrong_orders, 0);
  const nlohmann::json j = ToJson(both.summary);
  EXPECT_EQ(j.at("exposures").at(0).at("orders_repaired").get<int64_t>(),
            dim_only.summary.orders_repaired);

  // The same stack given twice is one decode: each repaired pixel counts once.
  const DecodeResult twice = DecodeExposures(s, {dim_stack, dim_stack});
  EXPECT_EQ(twice.summary.orders_repaired, dim_only.summary.orders_repaired);
  EXPECT_EQ(twice.repaired_px, dim_only.repaired_px);
}

// Pixels saturated in every exposure are named as such in the combination's message.
TEST(Decode, ExposuresSaturatedEverywhereAreExplained) {
  const PatternScheme s = MakeScheme("heterodyne-4x3", 1280, 800);
  const cv::Mat u = LinearProjectorMap(s, kSize);
  SyntheticStackOptions so;
  std::vector<cv::Mat> a = RenderSyntheticStack(s, u, so);
  so.seed = 2;
  std::vector<cv::Mat> b = RenderSyntheticStack(s, u, so);
  const cv::Rect sat(0, 0, kSize.width, kSize.height * 3 / 4);
  for (auto& im : a) im(sat).setTo(255);
  for (auto& im : b) im(sat).setTo(255);
  const DecodeResult both = DecodeExposures(s, {a, b});
  EXPECT_EQ(both.summary.rejected_saturated, sat.area());
  EXPECT_NE(both.summary.message.find("saturated in a phase-shift image in every exposure"),
            std::string::npos)
      << both.summary.message;
  EXPECT_NE(both.summary.message.find("2 exposures combined"), std::string::npos);
}

TEST(Gamma, RippleIsMeasurableAndRemovedByCompensation) {
  // 4-step and 3-step decoding under gamma 2.2: uncompensated error well above the gamma-free
  // error; pre-compensated patterns, or the decoder's table, within 10 % of it (issue 4).
  constexpr double kCompensatedMaxRatio = 1.10;
  constexpr double kTableMaxRatio = 1.5;
  for (const std::string name : {"heterodyne-4x3", "heterodyne-3x3"}) {
    const PatternScheme s = MakeScheme(name, 1280, 800);
    const cv::Mat u = LinearProjectorMap(s, kSize);
    SyntheticStackOptions so;
    so.modulation_dn = 90;
    so.noise_sigma_dn = 0.5;
    const double free_rms =
        Compare(s, Decode(s, RenderSyntheticStack(s, u, so)), u).wrapped_rms_rad;
    so.projector_gamma = 2.2;
    const auto raw = RenderSyntheticStack(s, u, so);
    const double raw_rms = Compare(s, Decode(s, raw), u).wrapped_rms_rad;
    DecodeOptions corr;
    corr.projector_gamma = 2.2;
    const double table_rms = Compare(s, Decode(s, raw, corr), u).wrapped_rms_rad;
    so.precompensate_gamma = 2.2;
    const double pre_rms = Compare(s, Decode(s, RenderSyntheticStack(s, u, so)), u).wrapped_rms_rad;
    EXPECT_GT(raw_rms, 1.5 * free_rms) << name;
    EXPECT_LT(pre_rms, kCompensatedMaxRatio * free_rms) << name;
    // The table removes the ripple but cannot undo the noise amplification where gamma
    // compresses the signal (3-step: ripple slope up to ~0.9), so it gets a looser bound than
    // pre-compensation; it must still beat the uncompensated decode.
    EXPECT_LT(table_rms, kTableMaxRatio * free_rms) << name;
    EXPECT_LT(table_rms, raw_rms) << name;
    std::cout << name << ": gamma-free " << free_rms << ", uncompensated " << raw_rms
              << ", pre-compensated " << pre_rms << ", table " << table_rms << " rad\n";
  }
}

// Issue 9: one source of truth for gamma. The scheme records what the patterns were
// pre-compensated for; the decoder corrects only the rest (projector_gamma / precompensation).
TEST(Gamma, DecoderCorrectsOnlyWhatTheSchemeDidNotPrecompensate) {
  PatternScheme s = MakeScheme("heterodyne-4x3", 1280, 800);
  const cv::Mat u = LinearProjectorMap(s, kSize);
  SyntheticStackOptions so;
  so.modulation_dn = 90;
  so.noise_sigma_dn = 0.5;
  so.projector_gamma = 2.2;
  // Fully pre-compensated: knowing the projector's gamma changes nothing (bit-identical).
  so.precompensate_gamma = 2.2;
  s.gamma_precompensation = 2.2;
  const auto full = RenderSyntheticStack(s, u, so);
  DecodeOptions known;
  known.projector_gamma = 2.2;
  EXPECT_DOUBLE_EQ(known.ResidualGamma(s), 1.0);
  const DecodeResult unknown_r = Decode(s, full);
  const DecodeResult known_r = Decode(s, full, known);
  EXPECT_EQ(cv::norm(unknown_r.absolute_phase, known_r.absolute_phase, cv::NORM_INF), 0.0);
  // Partly pre-compensated (1.6 for a 2.2 projector): the residual 2.2 / 1.6 is corrected, and
  // that beats both no correction and a correction for the whole 2.2 (the old second knob).
  so.precompensate_gamma = 1.6;
  s.gamma_precompensation = 1.6;
  const auto part = RenderSyntheticStack(s, u, so);
  EXPECT_NEAR(known.ResidualGamma(s), 2.2 / 1.6, 1e-12);
  const double none_rms = Compare(s, Decode(s, part), u).wrapped_rms_rad;
  const double residual_rms = Compare(s, Decode(s, part, known), u).wrapped_rms_rad;
  PatternScheme as_if_raw = s;
  as_if_raw.gamma_precompensation = 1.0;  // what the decoder did before: correct all of 2.2
  const double whole_rms = Compare(s, Decode(as_if_raw, part, known), u).wrapped_rms_rad;
  EXPECT_LT(residual_rms, none_rms);
  EXPECT_LT(residual_rms, whole_rms);
  // A gamma estimate from pre-compensated patterns would be the residual, not the projector's.
  const GammaEstimate est = EstimateGamma(s, part);
  EXPECT_FALSE(est.success);
  EXPECT_NE(est.message.find("pre-compensated"), std::string::npos) << est.message;
  DecodeOptions bad;
  bad.projector_gamma = -1;
  EXPECT_THROW(bad.Check(), Error);
}

TEST(Gamma, EstimatedFromAFlatSurface) {
  constexpr double kGammaTolerance = 0.1;
  const PatternScheme s = MakeScheme("heterodyne-4x3", 1280, 800);
  // A plane seen at ~2 camera pixels per projector pixel, so the ripple (N cycles per fringe
  // period) is well sampled.
  cv::Mat u(kSize, CV_32F);
  for (int y = 0; y < u.rows; ++y) {
    for (int x = 0; x < u.cols; ++x) u.at<float>(y, x) = 300.0f + 0.55f * x + 0.02f * y;
  }
  SyntheticStackOptions so;
  so.modulation_dn = 90;
  so.noise_sigma_dn = 1;
  so.projector_gamma = 2.2;
  const GammaEstimate est = EstimateGamma(s, RenderSyntheticStack(s, u, so));
  ASSERT_TRUE(est.success) << est.message;
  EXPECT_NEAR(est.gamma, 2.2, kGammaTolerance) << est.BriefReport();
  EXPECT_LT(est.ripple_rms_after_px, est.ripple_rms_before_px);
}

TEST(Decode, RealPhaseGrayCaptureIsPlausible) {
  FRINGE_SHARED_DATA_OR_SKIP(dir, "slsdk-stereo-phasegray");
  // Issue 4: valid-pixel fraction and jumps (> quarter period from the 5x5 median) <= 0.1 %.
  constexpr double kMinValidFraction = 0.4;
  constexpr double kMaxJumpFraction = 1e-3;
  const PatternScheme s = MakeScheme("slsdk-phasegray");
  for (const std::string cam : {"L", "R"}) {
    std::vector<cv::Mat> images;
    for (const auto& n : s.ImageNames()) images.push_back(io::ReadGrayImage(dir / cam / n));
    const DecodeResult r = Decode(s, images);
    const double jumps = JumpFraction(r.absolute_phase, r.mask, s.phase_sets[0].period_px);
    EXPECT_GT(r.summary.ValidFraction(), kMinValidFraction) << cam << r.summary.BriefReport();
    EXPECT_LT(jumps, kMaxJumpFraction) << cam;
    double lo, hi;
    cv::minMaxLoc(r.absolute_phase, &lo, &hi, nullptr, nullptr, r.mask);
    EXPECT_GE(lo, -1.0) << cam;
    EXPECT_LE(hi, 1920.0 + s.phase_sets[0].period_px) << cam;
    std::cout << cam << ": " << r.summary.BriefReport() << "; jumps " << jumps << "\n";
  }
}

}  // namespace
}  // namespace fringe::phase
