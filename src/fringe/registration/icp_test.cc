#include "fringe/registration/icp.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fringe/util/error.h"

namespace fringe::registration {
namespace {

constexpr double kRotTolDeg = 1e-3;  // noise-free synthetic surface: ICP must land on the truth
constexpr double kTransTolMm = 1e-3;

// A wavy height field z = 5 sin(x / 13) cos(y / 17) + 0.002 x^2 sampled on a 0.5 mm grid, normals
// analytic (toward +z, where the sensor would be after `sensor_from_world`).
PointCloud WavySurface(const Rigid3d& sensor_from_world, double x0, double x1) {
  PointCloud c;
  for (double x = x0; x <= x1; x += 0.5) {
    for (double y = -40; y <= 40; y += 0.5) {
      const double z = 5 * std::sin(x / 13) * std::cos(y / 17) + 0.002 * x * x;
      const double dzdx = 5 / 13.0 * std::cos(x / 13) * std::cos(y / 17) + 0.004 * x;
      const double dzdy = -5 / 17.0 * std::sin(x / 13) * std::sin(y / 17);
      c.points.push_back(sensor_from_world * Eigen::Vector3d(x, y, z));
      c.normals.push_back(
          sensor_from_world.RotateDirection(Eigen::Vector3d(-dzdx, -dzdy, 1).normalized()));
    }
  }
  return c;
}

TEST(AlignPointToPlane, RecoversAKnownMotion) {
  const PointCloud target = WavySurface(Rigid3d(), -40, 20);
  const Rigid3d source_from_world =
      Rigid3d::FromAxisAngle(Eigen::Vector3d(0.2, 1, 0.3).normalized(), 0.4, {10, -20, 300});
  const PointCloud source = WavySurface(source_from_world, -20, 40);
  const Rigid3d truth = source_from_world.Inverse();  // target(world)_from_source
  const Rigid3d start = Rigid3d::FromAxisAngle(Eigen::Vector3d(1, -1, 0.5).normalized(),
                                               2 * M_PI / 180, {1.5, -1, 2}) *
                        truth;
  IcpOptions o;
  o.initial_threshold_mm = 8;
  const IcpResult r = AlignPointToPlane(source, target, start, o);
  ASSERT_TRUE(r.summary.ok()) << r.summary.BriefReport();
  const RigidDifference d = Difference(r.world_from_sensor[1], truth);
  EXPECT_LT(d.angle_rad * 180 / M_PI, kRotTolDeg) << r.summary.BriefReport();
  EXPECT_LT(d.translation_mm, kTransTolMm);
  // The threshold shrank from level to level and the residual fell.
  const auto& l = r.summary.levels;
  EXPECT_LT(l.back().threshold_end_mm, o.initial_threshold_mm / 4);
  EXPECT_LT(l.back().rms_end_mm, l.front().rms_start_mm / 10);
  EXPECT_NEAR(r.overlap[1][0], 2.0 / 3 * o.trim_fraction, 0.05);  // two thirds shared, trimmed
}

TEST(RefineMultiView, MissingNormalsThrow) {
  PointCloud c = WavySurface(Rigid3d(), -10, 10);
  c.normals.clear();
  EXPECT_THROW(AlignPointToPlane(c, c, Rigid3d()), Error);
}

}  // namespace
}  // namespace fringe::registration
