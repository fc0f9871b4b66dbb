#include "fringe/calib/edges.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <opencv2/imgproc.hpp>
#include <random>

#include "fringe/util/error.h"
#include "fringe/util/random.h"

namespace fringe::calib {
namespace {

// A straight step edge (dark below the line n.x = offset, bright above), blurred by a Gaussian
// PSF, integrated over each pixel by supersampling, with Gaussian noise.
cv::Mat StraightEdge(int size, const Eigen::Vector2d& n, double offset, double blur_sigma,
                     double noise_sigma, uint64_t seed) {
  const int ss = 16;
  cv::Mat img(size, size, CV_32F);
  for (int v = 0; v < size; ++v) {
    for (int u = 0; u < size; ++u) {
      double sum = 0;
      for (int sy = 0; sy < ss; ++sy) {
        for (int sx = 0; sx < ss; ++sx) {
          const Eigen::Vector2d p(u - 0.5 + (sx + 0.5) / ss, v - 0.5 + (sy + 0.5) / ss);
          const double d = n.dot(p) - offset;
          // Blurred step evaluated analytically (Gaussian PSF across a straight edge).
          sum += 40 + 160 * 0.5 * (1 + std::erf(d / (std::sqrt(2.0) * blur_sigma)));
        }
      }
      img.at<float>(v, u) = static_cast<float>(sum / (ss * ss));
    }
  }
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0, noise_sigma);
  cv::Mat out(img.size(), CV_8U);
  for (int v = 0; v < size; ++v) {
    for (int u = 0; u < size; ++u) {
      out.at<uint8_t>(v, u) =
          cv::saturate_cast<uint8_t>(std::lround(img.at<float>(v, u) + noise(rng)));
    }
  }
  return out;
}

TEST(EdgeOptions, DefaultsPassCheck) { EXPECT_NO_THROW(EdgeOptions().Check()); }

TEST(EdgeOptions, CheckNamesField) {
  EdgeOptions o;
  o.search_half_width_px = -1;
  try {
    o.Check();
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("search_half_width_px"), std::string::npos);
  }
}

// Subpixel edge error on synthetic edges of known position, sigma = 1 DN noise, many angles and
// subpixel offsets: the mean error (bias) must stay below 0.02 px and the per-point RMS small.
TEST(LocateEdge, StraightEdgesKnownPosition) {
  constexpr double kMaxBiasPx = 0.02;
  constexpr double kMaxRmsPx = 0.05;
  const EdgeOptions options;
  std::uniform_real_distribution<double> uni(0, 1);
  double worst_bias = 0, sum_sq = 0;
  int count = 0;
  for (int k = 0; k < 8; ++k) {
    const double angle = k * M_PI / 8 + 0.1 * uni(util::GlobalRng());
    const Eigen::Vector2d n(std::cos(angle), std::sin(angle));
    const Eigen::Vector2d centre(20, 20);
    const double offset = n.dot(centre) + uni(util::GlobalRng()) - 0.5;
    const cv::Mat img =
        StraightEdge(41, n, offset, 0.8, std::getenv("EDGE_NONOISE") ? 0.0 : 1.0, 100 + k);
    const GradientImage grad(img, options.smoothing_sigma_px);
    const Eigen::Vector2d along(-n.y(), n.x());
    double sum = 0;
    int m = 0;
    for (int i = -8; i <= 8; ++i) {
      const Eigen::Vector2d seed = centre + i * along + 1.3 * n;
      const auto e = LocateEdge(grad, seed, n, options);
      ASSERT_TRUE(e.has_value()) << "angle " << angle << " i " << i;
      const double err = n.dot(e->position) - offset;
      sum += err;
      sum_sq += err * err;
      ++m;
      ++count;
    }
    worst_bias = std::max(worst_bias, std::abs(sum / m));
  }
  const double rms = std::sqrt(sum_sq / count);
  EXPECT_LT(worst_bias, kMaxBiasPx);
  EXPECT_LT(rms, kMaxRmsPx);
  std::cout << "edge bias max " << worst_bias << " px, rms " << rms << " px\n";
}

TEST(LocateEdge, NoEdgeOrWrongPolarity) {
  const EdgeOptions options;
  const Eigen::Vector2d n(1, 0);
  const cv::Mat img = StraightEdge(41, n, 20.2, 0.8, 0.0, 1);
  const GradientImage grad(img, options.smoothing_sigma_px);
  // Searching for a bright-to-dark edge along +x finds none.
  EXPECT_FALSE(LocateEdge(grad, {20, 20}, -n, options).has_value());
  // Far from the edge: nothing within the search range.
  EXPECT_FALSE(LocateEdge(grad, {6, 20}, n, options).has_value());
  const cv::Mat flat(41, 41, CV_8U, cv::Scalar(100));
  EXPECT_FALSE(LocateEdge(GradientImage(flat, 1.0), {20, 20}, n, options).has_value());
}

}  // namespace
}  // namespace fringe::calib
