#include "fringe/stereo/triangulation.h"

#include <gtest/gtest.h>

#include <random>

#include "fringe/util/random.h"

namespace fringe::stereo {
namespace {

TEST(Triangulation, DefaultOptionsPassCheck) { EXPECT_NO_THROW(TriangulationOptions().Check()); }

TEST(Triangulation, RoundTripInMeasuringVolume) {
  constexpr double kTolMm = 1e-6;
  constexpr double kTolPx = 1e-6;
  const StereoRig rig = StereoRig::Reference();
  std::uniform_real_distribution<double> xy(-100, 100), z(420, 580);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d p(xy(util::GlobalRng()), xy(util::GlobalRng()), z(util::GlobalRng()));
    const Eigen::Vector2d l = rig.left.Project(p);
    const Eigen::Vector2d r = rig.right.Project(rig.right_from_left * p);
    for (int iterations : {0, 2}) {
      TriangulationOptions options;
      options.refine_iterations = iterations;
      const TriangulatedPoint t = Triangulate(rig, l, r, options);
      ASSERT_TRUE(t.ok()) << ToString(t.status);
      EXPECT_LT((t.p_in_left - p).norm(), kTolMm);
      EXPECT_LT(t.reprojection_error_px, kTolPx);
    }
  }
}

TEST(Triangulation, RefinementLowersResidualUnderNoise) {
  constexpr double kNoisePx = 0.3;
  const StereoRig rig = StereoRig::Reference();
  std::normal_distribution<double> noise(0, kNoisePx);
  double sum_mid = 0, sum_opt = 0;
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3d p(10.0 * (i % 10) - 50, 7.0 * (i / 10) - 35, 500);
    const Eigen::Vector2d l =
        rig.left.Project(p) + Eigen::Vector2d(noise(util::GlobalRng()), noise(util::GlobalRng()));
    const Eigen::Vector2d r = rig.right.Project(rig.right_from_left * p) +
                              Eigen::Vector2d(noise(util::GlobalRng()), noise(util::GlobalRng()));
    TriangulationOptions mid;
    mid.refine_iterations = 0;
    const TriangulatedPoint a = Triangulate(rig, l, r, mid);
    const TriangulatedPoint b = Triangulate(rig, l, r);
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_LE(b.reprojection_error_px, a.reprojection_error_px + 1e-9);
    sum_mid += a.reprojection_error_px;
    sum_opt += b.reprojection_error_px;
  }
  EXPECT_LT(sum_opt, sum_mid);
}

TEST(Triangulation, ParallelRaysAreRejected) {
  const StereoRig rig = StereoRig::Reference();
  // A point at infinity: the same direction seen from both cameras.
  const Eigen::Vector3d d(0.05, -0.02, 1.0);
  const Eigen::Vector2d l = rig.left.Project(d);
  const Eigen::Vector2d r = rig.right.Project(rig.right_from_left.RotateDirection(d));
  EXPECT_EQ(Triangulate(rig, l, r).status, TriangulationStatus::kParallelRays);
}

TEST(Triangulation, PointBehindTheCamerasIsRejected) {
  const StereoRig rig = StereoRig::Reference();
  // Rays that diverge: left ray pointing far left, right ray far right.
  const Eigen::Vector2d l(0, 512), r(1279, 512);
  EXPECT_EQ(Triangulate(rig, l, r).status, TriangulationStatus::kBehindCamera);
}

}  // namespace
}  // namespace fringe::stereo
