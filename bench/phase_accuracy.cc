// Accuracy measures of bench_phase (see phase_accuracy.h).
#include "phase_accuracy.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "bench_timing.h"

namespace fringe::bench {

using phase::DecodeResult;
using phase::LinearProjectorMap;
using phase::PatternScheme;
using phase::SyntheticStackOptions;

namespace {

double WrapPi(double x) { return x - 2 * M_PI * std::round(x / (2 * M_PI)); }

// True wrapped phase of set 0 at projector coordinate u (docs/formats.md).
double TruePsi(const PatternScheme& s, double u) {
  const auto& set = s.phase_sets[0];
  return 2 * M_PI * (u + 0.5) / set.period_px + set.phase_offset_rad;
}

}  // namespace

Accuracy Evaluate(const PatternScheme& s, const DecodeResult& r, const cv::Mat& u_true,
                  const cv::Mat& region) {
  Accuracy a;
  double sum = 0;
  int64_t considered = 0;
  const double p = s.phase_sets[0].period_px;
  for (int y = 0; y < u_true.rows; ++y) {
    for (int x = 0; x < u_true.cols; ++x) {
      if (!region.empty() && !region.at<uint8_t>(y, x)) continue;
      ++considered;
      if (!r.mask.at<uint8_t>(y, x)) continue;
      const double u = u_true.at<float>(y, x);
      const double e = WrapPi(r.wrapped_phase.at<float>(y, x) - TruePsi(s, u));
      sum += e * e;
      ++a.valid;
      if (std::fabs(r.absolute_phase.at<float>(y, x) - u) > 0.25 * p) ++a.wrong;
    }
  }
  a.wrapped_rms_rad = std::sqrt(sum / std::max<int64_t>(a.valid, 1));
  a.wrong_order_fraction = static_cast<double>(a.wrong) / std::max<int64_t>(a.valid, 1);
  a.valid_fraction = static_cast<double>(a.valid) / std::max<int64_t>(considered, 1);
  return a;
}

double AbsoluteRmsPx(const PatternScheme& s, const DecodeResult& r, const cv::Mat& u_true) {
  const double p = s.phase_sets[0].period_px;
  double sum = 0;
  int64_t n = 0;
  for (int y = 0; y < u_true.rows; ++y) {
    for (int x = 0; x < u_true.cols; ++x) {
      if (!r.mask.at<uint8_t>(y, x)) continue;
      const double e = r.absolute_phase.at<float>(y, x) - u_true.at<float>(y, x);
      if (std::fabs(e) > 0.25 * p) continue;
      sum += e * e;
      ++n;
    }
  }
  return std::sqrt(sum / std::max<int64_t>(n, 1));
}

cv::Mat SceneMap(const PatternScheme& s, cv::Size size) {
  cv::Mat u = LinearProjectorMap(s, size);
  const double span = s.Span();
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      double du = 0;
      const double bx[3] = {0.25, 0.5, 0.75}, by[3] = {0.3, 0.7, 0.4}, sg[3] = {40, 25, 12};
      for (int k = 0; k < 3; ++k) {
        const double dx = x - bx[k] * size.width, dy = y - by[k] * size.height;
        du += 6.0 * std::exp(-(dx * dx + dy * dy) / (2 * sg[k] * sg[k]));
      }
      if (x > 0.6 * size.width && x < 0.85 * size.width && y > 0.15 * size.height &&
          y < 0.45 * size.height) {
        du += 7.3;
      }
      float& v = u.at<float>(y, x);
      v = static_cast<float>(std::clamp(v * 0.97 + 0.01 * span + du, 0.0, span - 1.0));
    }
  }
  return u;
}

SyntheticStackOptions Gaussian16(double b, double sigma, uint64_t seed) {
  SyntheticStackOptions o;
  o.bit_depth = 16;
  o.background_dn = 128 * 256.0;
  o.modulation_dn = b * 256.0;
  o.noise_sigma_dn = sigma * 256.0;
  o.quantize_patterns = false;
  o.seed = seed;
  return o;
}

PeerAccuracy EvaluatePeer(const cv::Mat& wrapped, const cv::Mat& unwrapped, const cv::Mat& mask,
                          const PatternScheme& s, const cv::Mat& u_true) {
  PeerAccuracy a;
  const double p = s.phase_sets[0].period_px;
  double best = 1e9;
  for (int sign : {1, -1}) {
    double c = 0, sn = 0;
    int64_t n = 0;
    for (int y = 0; y < u_true.rows; y += 2) {
      for (int x = 0; x < u_true.cols; x += 2) {
        if (!mask.at<uint8_t>(y, x)) continue;
        const double d = sign * wrapped.at<float>(y, x) - TruePsi(s, u_true.at<float>(y, x));
        c += std::cos(d);
        sn += std::sin(d);
        ++n;
      }
    }
    const double offset = std::atan2(sn, c);
    double sum = 0, sum_central = 0;
    int64_t valid = 0, central = 0;
    for (int y = 0; y < u_true.rows; ++y) {
      for (int x = 0; x < u_true.cols; ++x) {
        if (!mask.at<uint8_t>(y, x)) continue;
        const double e =
            WrapPi(sign * wrapped.at<float>(y, x) - TruePsi(s, u_true.at<float>(y, x)) - offset);
        sum += e * e;
        ++valid;
        if (x > u_true.cols / 10 && x < u_true.cols * 9 / 10 && y > u_true.rows / 10 &&
            y < u_true.rows * 9 / 10) {
          sum_central += e * e;
          ++central;
        }
      }
    }
    const double rms = std::sqrt(sum / std::max<int64_t>(valid, 1));
    if (rms < best) {
      best = rms;
      a.wrapped_rms_rad = rms;
      a.central_rms_rad = std::sqrt(sum_central / std::max<int64_t>(central, 1));
      a.valid_fraction = static_cast<double>(valid) / u_true.total();
      if (!unwrapped.empty()) {
        std::vector<double> d;
        for (int y = 0; y < u_true.rows; ++y) {
          for (int x = 0; x < u_true.cols; ++x) {
            if (!mask.at<uint8_t>(y, x)) continue;
            d.push_back(sign * unwrapped.at<float>(y, x) -
                        2 * M_PI * (u_true.at<float>(y, x) + 0.5) / p);
          }
        }
        const double med = Median(d);
        double su = 0;
        int64_t bad = 0;
        for (double v : d) {
          const double e = v - med;
          if (std::fabs(e) > M_PI) {
            ++bad;
          } else {
            su += e * e;
          }
        }
        a.unwrapped_rms_rad = std::sqrt(su / std::max<int64_t>(d.size() - bad, 1));
        a.unwrap_error_fraction = static_cast<double>(bad) / std::max<size_t>(d.size(), 1);
      }
    }
  }
  return a;
}

}  // namespace fringe::bench
