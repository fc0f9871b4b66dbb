#include "fringe/phase/gamma.h"

#include "fringe/phase/decode.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "fringe/phase/decode.h"
#include "fringe/util/error.h"

namespace fringe::phase {
namespace {

using util::CheckOption;
using util::StrCat;

double WrapPi(double x) { return x - 2.0 * M_PI * std::round(x / (2.0 * M_PI)); }

}  // namespace

namespace {

// Least-squares coefficients of the decoder's model I_k = A + a cos d_k - b sin d_k.
struct Demodulator {
  std::vector<double> cc, cs;
  explicit Demodulator(const std::vector<double>& shifts) {
    const int n = static_cast<int>(shifts.size());
    const cv::Mat c = DemodulationMatrix(shifts);
    for (int k = 0; k < n; ++k) {
      cc.push_back(c.at<double>(1, k));
      cs.push_back(c.at<double>(2, k));
    }
  }
  double Phase(double theta, const std::vector<double>& shifts, double mean, double amplitude,
               double gamma) const {
    double a = 0, b = 0;
    for (size_t k = 0; k < shifts.size(); ++k) {
      const double y =
          std::pow(std::max(0.0, mean + amplitude * std::cos(theta + shifts[k])), gamma);
      a += cc[k] * y;
      b += cs[k] * y;
    }
    return std::atan2(b, a);
  }
};

}  // namespace

double GammaDistortedPhase(double theta, const std::vector<double>& shifts, double mean,
                           double amplitude, double gamma) {
  return Demodulator(shifts).Phase(theta, shifts, mean, amplitude, gamma);
}

GammaPhaseCorrection::GammaPhaseCorrection(const std::vector<double>& shifts, double mean,
                                           double amplitude, double gamma, int table_size)
    : table_(table_size + 1),
      size_(table_size),
      scale_(static_cast<float>(table_size / (2 * M_PI))) {
  const Demodulator demod(shifts);
  for (int j = 0; j <= table_size; ++j) {
    const double psi = -M_PI + 2.0 * M_PI * j / table_size;
    // Solve theta + delta(theta) = psi by bisection: psi(theta) increases monotonically for any
    // gamma that keeps the ripple slope above -1 (all practical ones).
    auto g = [&](double theta) {
      return theta + WrapPi(demod.Phase(theta, shifts, mean, amplitude, gamma) - theta) - psi;
    };
    double lo = psi - 1.5, hi = psi + 1.5;
    for (int it = 0; it < 60; ++it) {
      const double mid = 0.5 * (lo + hi);
      (g(mid) < 0 ? lo : hi) = mid;
    }
    const double d = WrapPi(0.5 * (lo + hi) - psi);
    table_[j] = static_cast<float>(d);
    ripple_amplitude_ = std::max(ripple_amplitude_, std::fabs(d));
  }
}

void GammaEstimateOptions::Check() const {
  const char* o = "GammaEstimateOptions";
  CheckOption(min_gamma > 0, o, "min_gamma", min_gamma, "must be > 0");
  CheckOption(max_gamma > min_gamma, o, "max_gamma", max_gamma, "must be > min_gamma");
  CheckOption(row_step >= 1, o, "row_step", row_step, "must be >= 1");
}

std::string GammaEstimate::BriefReport() const {
  return StrCat(success ? "gamma " : "gamma estimation failed: ", success ? "" : message,
                success ? std::to_string(gamma) : "", " from ", pixels_used,
                " pixels; high-passed phase RMS ", ripple_rms_before_px, " -> ",
                ripple_rms_after_px, " px");
}

GammaEstimate EstimateGamma(const PatternScheme& scheme, const std::vector<cv::Mat>& images,
                            const GammaEstimateOptions& options) {
  options.Check();
  GammaEstimate est;
  // Pre-compensated patterns leave (almost) no ripple to fit: what could be measured is the
  // residual exponent, not the projector's, and reporting it as the gamma would make the
  // decoder's correction (projector_gamma / gamma_precompensation) wrong.
  if (scheme.gamma_precompensation != 1.0) {
    est.message =
        util::StrCat("the patterns were pre-compensated for gamma ", scheme.gamma_precompensation,
                     ": estimating the projector gamma needs uncompensated patterns");
    return est;
  }
  DecodeOptions dopt;
  const DecodeResult dec = Decode(scheme, images, dopt);
  // Runs of consecutive valid pixels along the image axis that follows the fringe direction.
  // Per phase set, the measured coordinate minus its running mean (a window longer than the
  // ripple period) keeps the ripple and the noise; the model's ripple, filtered the same way, is
  // fitted to it. Noise does not depend on gamma here, so the least-squares gamma is unbiased.
  const bool along_x = scheme.direction == FringeDirection::kVertical;
  auto orient = [&](const cv::Mat& m) { return along_x ? m : cv::Mat(m.t()); };
  const cv::Mat abs = orient(dec.absolute_phase);
  const cv::Mat mask = orient(dec.mask);
  const int half = 7;
  struct Run {
    int set;
    std::vector<float> psi, highpass;
  };
  std::vector<Run> runs;
  const int num_sets = static_cast<int>(scheme.phase_sets.size());
  std::vector<Demodulator> demods;
  for (int si = 0; si < num_sets; ++si) {
    const PhaseShiftSet& ps = scheme.phase_sets[si];
    const auto shifts = ps.Shifts();
    demods.emplace_back(shifts);
    cv::Mat ca(images[0].size(), CV_64F, cv::Scalar(0)), cs = ca.clone(), im;
    for (int k = 0; k < ps.steps; ++k) {
      images[scheme.PhaseImageIndex(si) + k].convertTo(im, CV_64F);
      ca += demods.back().cc[k] * im;
      cs += demods.back().cs[k] * im;
    }
    const cv::Mat ca_o = orient(ca), cs_o = orient(cs);
    for (int r = 0; r < abs.rows; r += options.row_step) {
      int c = 0;
      while (c < abs.cols) {
        while (c < abs.cols && !mask.at<uint8_t>(r, c)) ++c;
        const int begin = c;
        while (c < abs.cols && mask.at<uint8_t>(r, c)) ++c;
        if (c - begin < 4 * half) continue;
        Run run;
        run.set = si;
        std::vector<double> us;
        for (int x = begin; x < c; ++x) {
          const double psi = std::atan2(cs_o.at<double>(r, x), ca_o.at<double>(r, x));
          run.psi.push_back(static_cast<float>(psi));
          double f = (psi - ps.phase_offset_rad) / (2 * M_PI);
          f -= std::floor(f);
          const double k = std::round((abs.at<float>(r, x) + 0.5) / ps.period_px - f);
          us.push_back(ps.period_px * (k + f) - 0.5);
        }
        for (size_t i = half; i + half < us.size(); ++i) {
          double mean = 0;
          for (int k = -half; k <= half; ++k) mean += us[i + k];
          run.highpass.push_back(static_cast<float>(us[i] - mean / (2 * half + 1)));
        }
        est.pixels_used += static_cast<int64_t>(run.highpass.size());
        runs.push_back(std::move(run));
      }
    }
  }
  if (est.pixels_used < 100) {
    est.message = StrCat("only ", est.pixels_used, " usable pixels (need 100)");
    return est;
  }
  auto cost = [&](double gamma) {
    std::vector<GammaPhaseCorrection> corr;
    for (const auto& ps : scheme.phase_sets) {
      corr.emplace_back(ps.Shifts(), scheme.intensity_mean, scheme.intensity_amplitude, gamma, 512);
    }
    double sum = 0;
    std::vector<double> ripple;
    for (const Run& run : runs) {
      const double px_per_rad = scheme.phase_sets[run.set].period_px / (2 * M_PI);
      ripple.resize(run.psi.size());
      for (size_t i = 0; i < run.psi.size(); ++i) {
        ripple[i] = -(corr[run.set].Correct(run.psi[i]) - run.psi[i]) * px_per_rad;
      }
      for (size_t i = 0; i < run.highpass.size(); ++i) {
        double mean = 0;
        for (int k = 0; k <= 2 * half; ++k) mean += ripple[i + k];
        const double e = run.highpass[i] - (ripple[i + half] - mean / (2 * half + 1));
        sum += e * e;
      }
    }
    return std::sqrt(sum / est.pixels_used);
  };
  // The ripple of 4-step sets is not monotonic in gamma (it vanishes at gamma = 2, and 0.87
  // mimics 2.2), so scan a log grid for the global minimum, then refine by golden section.
  const int grid = 32;
  double best = 0, best_cost = std::numeric_limits<double>::infinity();
  const double la = std::log(options.min_gamma), lb = std::log(options.max_gamma);
  for (int i = 0; i <= grid; ++i) {
    const double x = la + (lb - la) * i / grid;
    const double cx = cost(std::exp(x));
    if (cx < best_cost) {
      best_cost = cx;
      best = x;
    }
  }
  const double step = (lb - la) / grid;
  double a = std::max(la, best - step), b = std::min(lb, best + step);
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  double x1 = b - g * (b - a), x2 = a + g * (b - a);
  double f1 = cost(std::exp(x1)), f2 = cost(std::exp(x2));
  while (b - a > 1e-3) {
    if (f1 < f2) {
      b = x2;
      x2 = x1;
      f2 = f1;
      x1 = b - g * (b - a);
      f1 = cost(std::exp(x1));
    } else {
      a = x1;
      x1 = x2;
      f1 = f2;
      x2 = a + g * (b - a);
      f2 = cost(std::exp(x2));
    }
  }
  est.gamma = std::exp(0.5 * (a + b));
  est.ripple_rms_before_px = cost(1.0);
  est.ripple_rms_after_px = cost(est.gamma);
  est.success = true;
  return est;
}

}  // namespace fringe::phase
