#include "fringe/registration/surface_noise.h"

#include <gtest/gtest.h>

#include <random>

#include "fringe/util/error.h"

namespace fringe::registration {
namespace {

// 16-neighbour plane fits on a 0.5 mm grid: the median of 1000 fits scatters by a few %.
constexpr double kNoiseRelTol = 0.15;

PointCloud NoisyPlane(double sigma_mm) {
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0, sigma_mm);
  PointCloud c;
  for (double x = -40; x <= 40; x += 0.5) {
    for (double y = -40; y <= 40; y += 0.5) c.points.emplace_back(x, y, 300 + n(rng));
  }
  return c;
}

TEST(EstimateSurfaceNoiseMm, RecoversThePlaneNoise) {
  for (const double sigma : {0.02, 0.1}) {
    EXPECT_NEAR(EstimateSurfaceNoiseMm(NoisyPlane(sigma)), sigma, kNoiseRelTol * sigma) << sigma;
  }
  EXPECT_LT(EstimateSurfaceNoiseMm(NoisyPlane(0)), 1e-9);
  EXPECT_EQ(EstimateSurfaceNoiseMm(PointCloud()), 0.0);
  EXPECT_THROW(EstimateSurfaceNoiseMm(NoisyPlane(0.1), 10, 3), Error);
}

}  // namespace
}  // namespace fringe::registration
