#include "fringe/calib/edges.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "fringe/util/error.h"

namespace fringe::calib {

void EdgeOptions::Check() const {
  using util::CheckOption;
  CheckOption(smoothing_sigma_px >= 0 && smoothing_sigma_px <= 5, "EdgeOptions",
              "smoothing_sigma_px", smoothing_sigma_px, "must be in [0, 5]");
  CheckOption(search_half_width_px > 0 && search_half_width_px <= 50, "EdgeOptions",
              "search_half_width_px", search_half_width_px, "must be in (0, 50]");
  CheckOption(min_gradient >= 0, "EdgeOptions", "min_gradient", min_gradient, "must be >= 0");
  CheckOption(max_angle_deg > 0 && max_angle_deg <= 90, "EdgeOptions", "max_angle_deg",
              max_angle_deg, "must be in (0, 90]");
}

GradientImage::GradientImage(const cv::Mat& gray, double smoothing_sigma_px) {
  if (gray.empty() || gray.channels() != 1) {
    throw Error("GradientImage: expected a non-empty single-channel image");
  }
  gray.convertTo(smooth_, CV_32F);
  if (smoothing_sigma_px > 0) {
    const int k = 2 * static_cast<int>(std::ceil(3 * smoothing_sigma_px)) + 1;
    cv::GaussianBlur(smooth_, smooth_, cv::Size(k, k), smoothing_sigma_px, smoothing_sigma_px,
                     cv::BORDER_REPLICATE);
  }
  cv::Sobel(smooth_, gx_, CV_32F, 1, 0, 3, 1.0 / 8, 0, cv::BORDER_REPLICATE);
  cv::Sobel(smooth_, gy_, CV_32F, 0, 1, 3, 1.0 / 8, 0, cv::BORDER_REPLICATE);
}

namespace {
inline double Bilinear(const cv::Mat& m, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= m.cols || y0 + 1 >= m.rows) return 0;
  const double fx = x - x0, fy = y - y0;
  const float* r0 = m.ptr<float>(y0);
  const float* r1 = m.ptr<float>(y0 + 1);
  return (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) +
         fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
}
// Cubic convolution (Keys, a = -0.5): far smaller peak-position bias than bilinear
// interpolation when sampling a smooth gradient profile between pixels.
inline void KeysWeights(double t, double w[4]) {
  constexpr double a = -0.5;
  auto k = [](double x) {
    x = std::abs(x);
    if (x <= 1) return (a + 2) * x * x * x - (a + 3) * x * x + 1;
    if (x < 2) return a * x * x * x - 5 * a * x * x + 8 * a * x - 4 * a;
    return 0.0;
  };
  w[0] = k(1 + t);
  w[1] = k(t);
  w[2] = k(1 - t);
  w[3] = k(2 - t);
}

inline double Bicubic(const cv::Mat& m, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  if (x0 < 1 || y0 < 1 || x0 + 2 >= m.cols || y0 + 2 >= m.rows) return Bilinear(m, x, y);
  double wx[4], wy[4];
  KeysWeights(x - x0, wx);
  KeysWeights(y - y0, wy);
  double sum = 0;
  for (int j = 0; j < 4; ++j) {
    const float* r = m.ptr<float>(y0 - 1 + j);
    const double row = wx[0] * r[x0 - 1] + wx[1] * r[x0] + wx[2] * r[x0 + 1] + wx[3] * r[x0 + 2];
    sum += wy[j] * row;
  }
  return sum;
}
}  // namespace

Eigen::Vector2d GradientImage::GradientCubic(const Eigen::Vector2d& p) const {
  return {Bicubic(gx_, p.x(), p.y()), Bicubic(gy_, p.x(), p.y())};
}

Eigen::Vector2d GradientImage::Gradient(const Eigen::Vector2d& p) const {
  return {Bilinear(gx_, p.x(), p.y()), Bilinear(gy_, p.x(), p.y())};
}

double GradientImage::Intensity(const Eigen::Vector2d& p) const {
  return Bilinear(smooth_, p.x(), p.y());
}

std::optional<EdgePoint> LocateEdge(const GradientImage& gradient, const Eigen::Vector2d& seed,
                                    const Eigen::Vector2d& normal_in, const EdgeOptions& options) {
  const Eigen::Vector2d n = normal_in.normalized();
  constexpr double kMargin = 3.0;
  double best_t = 0, best_g = -1;
  const double w = options.search_half_width_px;
  for (double t = -w; t <= w + 1e-9; t += 0.5) {
    const Eigen::Vector2d p = seed + t * n;
    if (!gradient.Inside(p, kMargin)) continue;
    const double g = gradient.Gradient(p).dot(n);
    if (g > best_g) {
      best_g = g;
      best_t = t;
    }
  }
  if (best_g < std::max(options.min_gradient, 1e-9)) return std::nullopt;
  const double cos_max = std::cos(options.max_angle_deg * M_PI / 180);
  Eigen::Vector2d p = seed + best_t * n;
  Eigen::Vector2d d = n;
  double mag = 0;
  int moves = 0;
  for (int pass = 0; pass < 6; ++pass) {
    if (!gradient.Inside(p, kMargin)) return std::nullopt;
    const Eigen::Vector2d g = gradient.GradientCubic(p);
    mag = g.norm();
    if (mag < std::max(options.min_gradient, 1e-9)) return std::nullopt;
    d = g / mag;
    if (d.dot(n) < cos_max) return std::nullopt;
    const double m_minus = gradient.GradientCubic(p - d).norm();
    const double m_plus = gradient.GradientCubic(p + d).norm();
    if (m_minus > mag || m_plus > mag) {
      // Not at the crest yet: climb one sample along the gradient direction.
      if (++moves > 3) return std::nullopt;
      p += (m_plus > m_minus ? 1.0 : -1.0) * d;
      continue;
    }
    if (m_minus <= 0 || m_plus <= 0) return std::nullopt;
    const double lm = std::log(m_minus), l0 = std::log(mag), lp = std::log(m_plus);
    const double denom = lm - 2 * l0 + lp;
    if (!(denom < 0)) return std::nullopt;
    const double delta = std::clamp(0.5 * (lm - lp) / denom, -1.0, 1.0);
    p += delta * d;
    if (std::abs(delta) < 1e-3) break;
  }
  if ((p - seed).dot(n) > w + 1 || (p - seed).dot(n) < -w - 1) return std::nullopt;
  EdgePoint e;
  e.position = p;
  e.normal = d;
  e.strength = mag;
  return e;
}

}  // namespace fringe::calib
