#include "fringe/geometry/grid_projection.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "fringe/geometry/camera.h"

namespace fringe {
namespace {

// A camera with the reference rig's kind of distortion seeing a tilted, gently curved surface:
// each valid slot holds the point its pixel's ray meets (as a reconstruction does), plus noise
// along the ray.
OrganizedPointCloud RenderSurface(const CameraModel& cam, double noise_mm) {
  OrganizedPointCloud g(cam.width, cam.height);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0, noise_mm);
  for (int r = 0; r < cam.height; ++r) {
    for (int c = 0; c < cam.width; ++c) {
      if ((c - 40) * (c - 40) + (r - 30) * (r - 30) < 100) continue;  // a hole
      const Eigen::Vector3d d = cam.Ray(Eigen::Vector2d(c, r));
      // Depth along the ray: a plane tilted about both axes with a bump.
      const double z = 300 + 30 * d.x() / d.z() - 20 * d.y() / d.z() +
                       5 * std::exp(-((d.x() * d.x() + d.y() * d.y()) / 0.01));
      const size_t i = g.index(c, r);
      g.valid[i] = 1;
      g.cloud.points[i] = (z / d.z()) * d + noise(rng) * d;
    }
  }
  return g;
}

CameraModel DistortedCamera() {
  CameraModel cam;
  cam.width = 160;
  cam.height = 128;
  cam.fx = cam.fy = 312.5;
  cam.cx = 79.5;
  cam.cy = 63.5;
  cam.k1 = -0.08;
  cam.k2 = 0.05;
  cam.p1 = 3e-4;
  cam.p2 = -2e-4;
  return cam;
}

TEST(GridProjection, FitsADistortedCameraGrid) {
  const CameraModel cam = DistortedCamera();
  const OrganizedPointCloud g = RenderSurface(cam, 0.01);
  const GridProjection proj = GridProjection::Fit(g);
  ASSERT_TRUE(proj.fitted());
  EXPECT_EQ(proj.width(), cam.width);
  EXPECT_EQ(proj.height(), cam.height);
  // A cubic in the normalized coordinates models this distortion to well below a pixel.
  constexpr double kMaxFitErrorPx = 0.1;
  EXPECT_LT(proj.fit_error_px(), kMaxFitErrorPx);
  // Every valid point projects onto its own slot within the reported error, and the reported
  // error is the largest one (some point reaches at least half of it).
  double worst = 0;
  for (int r = 0; r < g.height; ++r) {
    for (int c = 0; c < g.width; ++c) {
      const size_t i = g.index(c, r);
      if (!g.valid[i]) continue;
      Eigen::Vector2f cr;
      ASSERT_TRUE(proj.Project(g.cloud.points[i].cast<float>(), &cr));
      const double err = std::hypot(cr.x() - c, cr.y() - r);
      worst = std::max(worst, err);
      ASSERT_LE(err, proj.fit_error_px() + 1e-3) << c << "," << r;
    }
  }
  EXPECT_GT(worst, 0.5 * proj.fit_error_px());
  // Off-grid points project where the camera model puts them.
  const Eigen::Vector3d q(12.0, -7.0, 250.0);
  Eigen::Vector2f cr;
  ASSERT_TRUE(proj.Project(q.cast<float>(), &cr));
  EXPECT_NEAR((cr.cast<double>() - cam.Project(q)).norm(), 0, 2 * kMaxFitErrorPx);
  // Behind the sensor: nothing.
  EXPECT_FALSE(proj.Project(Eigen::Vector3f(1, 1, -5), &cr));
}

TEST(GridProjection, DiscHoldsEveryPointWithinTheRadius) {
  const CameraModel cam = DistortedCamera();
  const OrganizedPointCloud g = RenderSurface(cam, 0.05);
  const GridProjection proj = GridProjection::Fit(g);
  ASSERT_TRUE(proj.fitted());
  constexpr float kRadiusMm = 3.0f;
  int checked = 0;
  for (int r = 5; r < g.height; r += 17) {
    for (int c = 3; c < g.width; c += 13) {
      const size_t i = g.index(c, r);
      if (!g.valid[i]) continue;
      // A query point off the surface (as another view's point would be).
      const Eigen::Vector3f p =
          g.cloud.points[i].cast<float>() + Eigen::Vector3f(0.4f, -0.3f, 0.5f);
      GridProjection::Disc d;
      ASSERT_TRUE(proj.DiscOf(p, kRadiusMm, &d));
      EXPECT_GT(d.radius_px, 0);
      for (size_t j = 0; j < g.valid.size(); ++j) {
        if (!g.valid[j] || (g.cloud.points[j].cast<float>() - p).norm() > kRadiusMm) continue;
        const float dc = static_cast<float>(j % g.width) - d.col;
        const float dr = static_cast<float>(j / g.width) - d.row;
        ASSERT_LE(std::hypot(dc, dr), d.radius_px) << "slot " << j << " outside the disc";
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 1000);
  // The sphere reaching behind the sensor has no disc.
  GridProjection::Disc d;
  EXPECT_FALSE(proj.DiscOf(Eigen::Vector3f(0, 0, 2), kRadiusMm, &d));
}

TEST(GridProjection, TooFewOrDegeneratePointsAreNotFitted) {
  OrganizedPointCloud g(20, 20);
  for (int k = 0; k < 50; ++k) {  // fewer than the fit needs
    g.valid[k] = 1;
    g.cloud.points[k] = Eigen::Vector3d(k % 20, k / 20, 100);
  }
  GridProjection proj = GridProjection::Fit(g);
  EXPECT_FALSE(proj.fitted());
  EXPECT_TRUE(std::isnan(proj.fit_error_px()));
  Eigen::Vector2f cr;
  EXPECT_FALSE(proj.Project(Eigen::Vector3f(0, 0, 100), &cr));
  // Enough points, but all on one ray: no fit.
  for (size_t k = 0; k < g.valid.size(); ++k) {
    g.valid[k] = 1;
    g.cloud.points[k] = Eigen::Vector3d(1, 2, 100 + k);
  }
  proj = GridProjection::Fit(g);
  // Whatever the solver returns, the points cannot reach their slots: the error says so (fusion
  // refuses a grid beyond 4 px).
  EXPECT_FALSE(proj.fit_error_px() < 4);
}

}  // namespace
}  // namespace fringe
