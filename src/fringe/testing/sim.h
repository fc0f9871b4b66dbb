// Small helpers shared by the simulator's tests (not part of the library API).
#pragma once

#include <cmath>
#include <opencv2/core.hpp>
#include <vector>

namespace fringe::sim::testing {

// N-step sinusoidal fringes along projector x with `period_px`, CV_32F in [0, 1]:
// I_k(x) = 0.5 + 0.5 cos(2 pi x / period - 2 pi k / N).
inline std::vector<cv::Mat> SinusoidPatterns(int width, int height, double period_px, int steps) {
  std::vector<cv::Mat> out;
  for (int k = 0; k < steps; ++k) {
    cv::Mat m(height, width, CV_32F);
    for (int c = 0; c < width; ++c) {
      const float v =
          static_cast<float>(0.5 + 0.5 * std::cos(2 * M_PI * c / period_px - 2 * M_PI * k / steps));
      for (int r = 0; r < height; ++r) m.at<float>(r, c) = v;
    }
    out.push_back(m);
  }
  return out;
}

// Wrapped phase in [0, 2 pi) of the N-step images at (row, col): the phase of
// sum_k I_k exp(i 2 pi k / N).
inline double WrappedPhase(const std::vector<cv::Mat>& images, int row, int col) {
  const int n = static_cast<int>(images.size());
  double s = 0, c = 0;
  for (int k = 0; k < n; ++k) {
    const double v = images[k].at<float>(row, col);
    s += v * std::sin(2 * M_PI * k / n);
    c += v * std::cos(2 * M_PI * k / n);
  }
  double phi = std::atan2(s, c);
  if (phi < 0) phi += 2 * M_PI;
  return phi;
}

}  // namespace fringe::sim::testing
