#include "fringe/calib/ellipse.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "fringe/util/random.h"

namespace fringe::calib {
namespace {

std::vector<Eigen::Vector2d> Sample(const Ellipse& e, int n, double noise, double arc = 2 * M_PI) {
  std::normal_distribution<double> g(0, noise);
  std::vector<Eigen::Vector2d> pts;
  for (int i = 0; i < n; ++i) {
    const double t = arc * i / n;
    pts.push_back(e.PointAt(t) + e.NormalAt(t) * (noise > 0 ? g(util::GlobalRng()) : 0.0));
  }
  return pts;
}

TEST(Ellipse, ConicRoundTrip) {
  Ellipse e;
  e.centre = {312.4, -80.2};
  e.a = 25;
  e.b = 11;
  e.angle = 0.7;
  const auto back = EllipseFromConic(e.Conic());
  ASSERT_TRUE(back);
  EXPECT_NEAR(back->centre.x(), e.centre.x(), 1e-9);
  EXPECT_NEAR(back->centre.y(), e.centre.y(), 1e-9);
  EXPECT_NEAR(back->a, e.a, 1e-9);
  EXPECT_NEAR(back->b, e.b, 1e-9);
  EXPECT_NEAR(back->angle, e.angle, 1e-9);
  for (int i = 0; i < 10; ++i) {
    const Eigen::Vector2d p = e.PointAt(i * 0.6);
    EXPECT_NEAR(e.SignedDistance(p), 0, 1e-9);
    EXPECT_NEAR(e.SignedDistance(p + 0.5 * e.NormalAt(i * 0.6)), 0.5, 1e-9);
  }
}

TEST(EllipseFitOptions, DefaultsPassCheck) { EXPECT_NO_THROW(EllipseFitOptions().Check()); }

TEST(FitEllipse, ExactAndNoisy) {
  constexpr double kExactTol = 1e-8;
  constexpr double kNoisyCentreTol = 0.01;  // px, 200 points at 0.05 px noise
  Ellipse e;
  e.centre = {640.3, 511.7};
  e.a = 40;
  e.b = 18;
  e.angle = -0.4;
  const auto direct = FitEllipseDirect(Sample(e, 50, 0));
  ASSERT_TRUE(direct);
  EXPECT_NEAR((direct->centre - e.centre).norm(), 0, kExactTol);
  EXPECT_NEAR(direct->a, e.a, kExactTol);
  const auto fit = FitEllipse(Sample(e, 200, 0.05));
  ASSERT_TRUE(fit);
  EXPECT_LT((fit->ellipse.centre - e.centre).norm(), kNoisyCentreTol);
  EXPECT_NEAR(fit->ellipse.a, e.a, 0.01);
  EXPECT_NEAR(fit->ellipse.b, e.b, 0.01);
  EXPECT_NEAR(fit->rms_residual, 0.05, 0.01);
}

TEST(FitEllipse, PartialArcAndOutliers) {
  Ellipse e;
  e.centre = {100, 50};
  e.a = 30;
  e.b = 20;
  e.angle = 0.2;
  auto pts = Sample(e, 120, 0.03, 1.2 * M_PI);  // features cut by the image border
  pts.push_back({100, 50});                     // gross outliers
  pts.push_back({140, 90});
  const auto fit = FitEllipse(pts);
  ASSERT_TRUE(fit);
  EXPECT_EQ(fit->num_outliers, 2);
  EXPECT_LT((fit->ellipse.centre - e.centre).norm(), 0.05);
}

TEST(FitEllipse, Degenerate) {
  EXPECT_FALSE(FitEllipseDirect({{0, 0}, {1, 1}, {2, 2}}));
  std::vector<Eigen::Vector2d> line;
  for (int i = 0; i < 20; ++i) line.push_back({i, 2.0 * i});
  EXPECT_FALSE(FitEllipse(line));
}

// The image of the common centre of two concentric circles under a strong perspective
// homography: exact from the pencil, while the ellipse centres are biased.
TEST(ConcentricCentre, ExactUnderPerspective) {
  constexpr double kTol = 1e-6;  // px, exact conics
  Eigen::Matrix3d k;
  k << 2500, 0, 640, 0, 2500, 512, 0, 0, 1;
  const Eigen::Matrix3d r =
      Eigen::AngleAxisd(60 * M_PI / 180, Eigen::Vector3d(1, 0.3, 0).normalized())
          .toRotationMatrix();
  const Eigen::Vector3d t(-30, 20, 400);
  Eigen::Matrix3d h;
  h.col(0) = k * r.col(0);
  h.col(1) = k * r.col(1);
  h.col(2) = k * t;
  const Eigen::Vector2d c(48, -24);
  const Eigen::Vector2d truth = (h * Eigen::Vector3d(c.x(), c.y(), 1)).hnormalized();
  const Eigen::Matrix3d outer = ProjectCircle(h, c, 8.0);
  const Eigen::Matrix3d inner = ProjectCircle(h, c, 4.5);
  const auto centre = ConcentricCentre(outer, inner);
  ASSERT_TRUE(centre);
  EXPECT_LT((*centre - truth).norm(), kTol);
  const auto swapped = ConcentricCentre(inner, outer);
  ASSERT_TRUE(swapped);
  EXPECT_LT((*swapped - truth).norm(), kTol);
  // The outer ellipse's centre is off by a clearly measurable amount here.
  const double bias = (*ConicCentre(outer) - truth).norm();
  EXPECT_GT(bias, 0.1);
  std::cout << "ellipse-centre bias " << bias << " px, pole-polar error "
            << (*centre - truth).norm() << " px\n";
  // Identical conics have no vanishing line.
  EXPECT_FALSE(ConcentricCentre(outer, outer));
}

// Fitted from noisy edge samples of both projected circles.
TEST(ConcentricCentre, FromNoisyFits) {
  constexpr double kTol = 0.02;  // px
  Eigen::Matrix3d k;
  k << 2500, 0, 640, 0, 2500, 512, 0, 0, 1;
  const Eigen::Matrix3d r =
      Eigen::AngleAxisd(55 * M_PI / 180, Eigen::Vector3d(0.2, 1, 0).normalized())
          .toRotationMatrix();
  Eigen::Matrix3d h;
  h.col(0) = k * r.col(0);
  h.col(1) = k * r.col(1);
  h.col(2) = k * Eigen::Vector3d(10, -5, 450);
  const Eigen::Vector2d c(0, 0);
  const Eigen::Vector2d truth = (h * Eigen::Vector3d(0, 0, 1)).hnormalized();
  const auto eo = EllipseFromConic(ProjectCircle(h, c, 8.0));
  const auto ei = EllipseFromConic(ProjectCircle(h, c, 4.5));
  ASSERT_TRUE(eo && ei);
  const auto fo = FitEllipse(Sample(*eo, 240, 0.03));
  const auto fi = FitEllipse(Sample(*ei, 140, 0.03));
  ASSERT_TRUE(fo && fi);
  const auto centre = ConcentricCentre(fo->ellipse.Conic(), fi->ellipse.Conic());
  ASSERT_TRUE(centre);
  EXPECT_LT((*centre - truth).norm(), kTol);
}

}  // namespace
}  // namespace fringe::calib

namespace fringe::calib {
namespace {

// Orthogonal distance (Newton foot point) against a brute-force oracle: dense sampling.
TEST(Ellipse, SignedDistanceMatchesBruteForce) {
  constexpr double kTol = 1e-4;  // oracle resolution
  Ellipse e;
  e.centre = {3, -2};
  e.a = 20;
  e.b = 4;
  e.angle = 0.3;
  std::uniform_real_distribution<double> u(-30, 30);
  for (int i = 0; i < 40; ++i) {
    const Eigen::Vector2d p(u(util::GlobalRng()), u(util::GlobalRng()));
    double best = 1e300;
    for (int k = 0; k < 200000; ++k)
      best = std::min(best, (e.PointAt(2 * M_PI * k / 200000) - p).norm());
    EXPECT_NEAR(std::abs(e.SignedDistance(p)), best, kTol) << p.transpose();
  }
}

}  // namespace
}  // namespace fringe::calib
