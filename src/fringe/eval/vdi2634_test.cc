#include "fringe/eval/vdi2634.h"

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <random>

#include "fringe/util/random.h"

namespace fringe::eval {
namespace {

// Fibonacci directions on the unit sphere, n even, in antipodal pairs (d, -d).
std::vector<Eigen::Vector3d> AntipodalDirections(int pairs) {
  std::vector<Eigen::Vector3d> d;
  const double golden = M_PI * (3 - std::sqrt(5.0));
  for (int i = 0; i < pairs; ++i) {
    const double z = 1 - (i + 0.5) / pairs;  // upper hemisphere
    const double r = std::sqrt(1 - z * z);
    const Eigen::Vector3d u(r * std::cos(golden * i), r * std::sin(golden * i), z);
    d.push_back(u);
    d.push_back(-u);
  }
  return d;
}

// A sphere whose radial residuals are +a for pairs with even index, -a for odd: by symmetry the
// least-squares sphere is the true one, so PF = 2a and PS = 0 exactly.
std::vector<Eigen::Vector3d> SymmetricSphere(const Eigen::Vector3d& c, double r, double a,
                                             int pairs) {
  const auto dirs = AntipodalDirections(pairs);
  std::vector<Eigen::Vector3d> pts;
  for (size_t i = 0; i < dirs.size(); ++i) {
    const double e = (i / 2) % 2 == 0 ? a : -a;
    pts.push_back(c + (r + e) * dirs[i]);
  }
  return pts;
}

TEST(Vdi2634, DefaultOptionsPassCheck) { EXPECT_NO_THROW(VdiOptions().Check()); }

TEST(Vdi2634, FitSphereIsExactOnACap) {
  const Eigen::Vector3d c(10, -20, 500);
  std::vector<Eigen::Vector3d> pts;
  for (const auto& d : AntipodalDirections(200)) {
    if (d.z() < -0.3) pts.push_back(c + 12.5 * d);  // a cap facing a camera at the origin
  }
  const SphereFit fit = FitSphere(pts);
  ASSERT_TRUE(fit.ok);
  EXPECT_LT((fit.centre - c).norm(), 1e-9);
  EXPECT_NEAR(fit.radius_mm, 12.5, 1e-9);
  EXPECT_FALSE(FitSphere({c, c, c}).ok);
}

TEST(Vdi2634, SphereFiguresKnownAnswer) {
  constexpr double kA = 0.01;
  const auto pts = SymmetricSphere({1, 2, 3}, 12.5, kA, 1000);
  const SphereResult r = SphereFigures(pts, 25.0, 0.0);
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r.PF_mm, 2 * kA, 1e-9);
  EXPECT_NEAR(r.PS_mm, 0, 1e-9);
  EXPECT_NEAR(r.diameter_mm, 25.0, 1e-9);
}

TEST(Vdi2634, DiscardAllowanceRemovesOutliers) {
  constexpr double kA = 0.01;
  auto pts = SymmetricSphere({0, 0, 0}, 12.5, kA, 1000);  // 2000 points
  // Six gross outliers: 0.3 % of 2006 points = 6 may go, leaving the symmetric set.
  for (int i = 0; i < 6; ++i) pts.push_back(Eigen::Vector3d(0, 0, 13.5 + 0.1 * i));
  const SphereResult with = SphereFigures(pts, 25.0);
  const SphereResult without = SphereFigures(pts, 25.0, 0.0);
  ASSERT_TRUE(with.ok() && without.ok());
  EXPECT_EQ(with.discarded, 6);
  EXPECT_EQ(with.points, 2000);
  EXPECT_NEAR(with.PF_mm, 2 * kA, 1e-9);
  EXPECT_GT(without.PF_mm, 0.9);
}

TEST(Vdi2634, KeepAfterDiscardChoosesTheEnds) {
  const std::vector<double> r = {0.0, 5.0, 0.1, -3.0, 0.2, 0.05, 0.15, 0.12, 0.11, 0.13};
  // floor(0.2 * 10) = 2 points go: -3 and 5.
  const auto keep = KeepAfterDiscard(r, 0.2);
  ASSERT_EQ(keep.size(), 8u);
  for (size_t i : keep) EXPECT_TRUE(i != 1 && i != 3);
}

TEST(Vdi2634, PlaneFiguresKnownAnswer) {
  constexpr double kA = 0.02;
  std::vector<Eigen::Vector3d> pts;
  const Eigen::Vector3d n = Eigen::Vector3d(0.1, -0.2, 1).normalized();
  const Eigen::Vector3d u = n.unitOrthogonal(), v = n.cross(u);
  for (int i = -20; i <= 20; ++i) {
    for (int j = -20; j <= 20; ++j) {
      const double e = ((i + j) % 2 == 0 ? kA : -kA);
      // Checkerboard residuals on a symmetric grid: the LS plane is the true plane.
      pts.push_back(Eigen::Vector3d(5, 6, 400) + 3.0 * i * u + 2.0 * j * v + e * n);
    }
  }
  const PlaneResult r = PlaneFigures(pts, 0.0);
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r.F_mm, 2 * kA, 1e-6);
  EXPECT_GT(std::abs(r.normal.dot(n)), 1 - 1e-9);
}

// A noisy sphere cap and a plane behind it, as a camera at the origin would see them.
PointCloud SphereOnBackground(const std::vector<Eigen::Vector3d>& centres, double radius,
                              double noise, bool with_normals) {
  std::normal_distribution<double> gauss(0, noise);
  PointCloud cloud;
  for (const auto& c : centres) {
    for (const auto& d : AntipodalDirections(3000)) {
      const Eigen::Vector3d p = c + radius * d;
      if (d.dot(-p.normalized()) < 0.2) continue;  // not visible
      cloud.points.push_back(p + gauss(util::GlobalRng()) * d);
      if (with_normals) cloud.normals.push_back(d);
    }
  }
  for (int i = -60; i <= 60; ++i) {
    for (int j = -60; j <= 60; ++j) {
      cloud.points.emplace_back(3.0 * i, 2.0 * j, 600 + gauss(util::GlobalRng()));
      if (with_normals) cloud.normals.emplace_back(0, 0, -1);
    }
  }
  return cloud;
}

TEST(Vdi2634, EvaluateSphereFindsItInClutter) {
  constexpr double kNoise = 0.01;
  constexpr double kPsTol = 0.005;
  for (bool normals : {true, false}) {
    const PointCloud cloud = SphereOnBackground({{20, -10, 500}}, 12.5, kNoise, normals);
    const SphereResult r = EvaluateSphere(cloud, 25.0);
    ASSERT_TRUE(r.ok()) << r.BriefReport();
    EXPECT_NEAR(r.PS_mm, 0, kPsTol) << r.BriefReport();
    EXPECT_LT((r.centre - Eigen::Vector3d(20, -10, 500)).norm(), kPsTol);
    EXPECT_GT(r.PF_mm, 4 * kNoise);  // the range of ~2000 Gaussian residuals is ~7 sigma
    EXPECT_LT(r.PF_mm, 10 * kNoise);
    EXPECT_GT(r.points, 1000);
  }
}

TEST(Vdi2634, EvaluateBallBar) {
  constexpr double kNoise = 0.01;
  constexpr double kSdTol = 0.005;
  const Eigen::Vector3d a(-60, 5, 520), b(80, -5, 480);
  const PointCloud cloud = SphereOnBackground({a, b}, 12.5, kNoise, true);
  const BallBarResult r = EvaluateBallBar(cloud, 25.0, (a - b).norm());
  ASSERT_TRUE(r.ok()) << r.BriefReport();
  EXPECT_NEAR(r.SD_mm, 0, kSdTol);
}

TEST(Vdi2634, BallBarIgnoresADistractorSphereOfAnotherDiameter) {
  // The VDI scene has a 30 mm sphere beside a ball bar of 20 mm spheres: only the sphere at the
  // calibrated distance from the first may be taken as the second.
  constexpr double kNoise = 0.01;
  constexpr double kSdTol = 0.005;
  const Eigen::Vector3d a(-75, 35, 520), b(75, 35, 520), distractor(-60, -45, 505);
  PointCloud cloud = SphereOnBackground({a, b}, 10.0, kNoise, false);
  const PointCloud big = SphereOnBackground({distractor}, 15.0, kNoise, false);
  cloud.points.insert(cloud.points.end(), big.points.begin(), big.points.end());
  const BallBarResult r = EvaluateBallBar(cloud, 20.0, (a - b).norm());
  ASSERT_TRUE(r.ok()) << r.BriefReport();
  EXPECT_NEAR(r.SD_mm, 0, kSdTol);
}

// Without a calibrated diameter the sphere is found with a free radius (not the background
// plane, which a large sphere fits over a small cap): PF, RMS and the fitted diameter, no PS.
TEST(Vdi2634, EvaluateSphereWithoutADiameterGivesFormFiguresOnly) {
  constexpr double kNoise = 0.01;
  constexpr double kDiameterTol = 0.005;
  constexpr double kCentreTol = 0.005;
  for (bool normals : {true, false}) {
    const Eigen::Vector3d centre(20, -10, 500);
    const PointCloud cloud = SphereOnBackground({centre}, 12.5, kNoise, normals);
    const SphereResult r = EvaluateSphere(cloud, 0.0);
    ASSERT_TRUE(r.ok()) << r.BriefReport();
    EXPECT_FALSE(r.has_size_error());
    EXPECT_NEAR(r.diameter_mm, 25.0, kDiameterTol) << r.BriefReport();
    EXPECT_LT((r.centre - centre).norm(), kCentreTol) << r.BriefReport();
    EXPECT_GT(r.PF_mm, 4 * kNoise);
    EXPECT_LT(r.PF_mm, 10 * kNoise);
    EXPECT_NEAR(r.rms_mm, kNoise, 0.2 * kNoise);
    EXPECT_GT(r.points, 1000);
    const nlohmann::json j = ToJson(r);
    EXPECT_FALSE(j.contains("PS_mm")) << j.dump();
    EXPECT_TRUE(j.contains("PF_mm") && j.contains("diameter_mm") && j.contains("rms_mm"));
    EXPECT_NE(r.BriefReport().find("no calibrated diameter"), std::string::npos);
    // The same with the diameter: PS appears, the form figures agree.
    const SphereResult with = EvaluateSphere(cloud, 25.0);
    ASSERT_TRUE(with.ok()) << with.BriefReport();
    EXPECT_TRUE(with.has_size_error());
    EXPECT_TRUE(ToJson(with).contains("PS_mm"));
    EXPECT_NEAR(with.diameter_mm, r.diameter_mm, 1e-3);
  }
  // A plane alone holds no sphere, whatever radius.
  const SphereResult none = EvaluateSphere(SphereOnBackground({}, 12.5, kNoise, false), 0.0);
  EXPECT_FALSE(none.ok()) << none.BriefReport();
}

// Ball-bar labels follow the spheres' positions (sphere_a at the smaller coordinate along the
// axis on which the centres differ most), not the order of points or which sphere the search
// happens to find first; with or without a calibrated diameter.
TEST(Vdi2634, BallBarLabelsByPositionNotPointOrder) {
  constexpr double kNoise = 0.01;
  constexpr double kCentreTol = 0.005;
  constexpr double kSdTol = 0.005;
  const Eigen::Vector3d low_x(-60, 5, 520), high_x(80, -5, 480);
  // Put the sphere at high x first in the cloud, and make it the one with more points (the
  // bigger share of the subsample), so that "first found" would be the high-x sphere.
  PointCloud cloud =
      SphereOnBackground({high_x, high_x + Eigen::Vector3d(0, 0, 0)}, 12.5, kNoise, false);
  const PointCloud low = SphereOnBackground({low_x}, 12.5, kNoise, false);
  cloud.points.insert(cloud.points.end(), low.points.begin(), low.points.end());
  PointCloud reversed = cloud;
  std::reverse(reversed.points.begin(), reversed.points.end());
  const double distance = (high_x - low_x).norm();
  for (const PointCloud* c : {&cloud, &reversed}) {
    for (double diameter : {25.0, 0.0}) {
      for (uint64_t seed : {1, 2}) {
        VdiOptions o;
        o.seed = seed;
        const BallBarResult r = EvaluateBallBar(*c, diameter, distance, o);
        ASSERT_TRUE(r.ok()) << r.BriefReport();
        EXPECT_LT((r.sphere_a.centre - low_x).norm(), kCentreTol) << r.BriefReport();
        EXPECT_LT((r.sphere_b.centre - high_x).norm(), kCentreTol) << r.BriefReport();
        EXPECT_NEAR(r.SD_mm, 0, kSdTol);
        EXPECT_EQ(r.sphere_a.has_size_error(), diameter > 0);
      }
    }
  }
}

TEST(Vdi2634, EvaluatePlaneAndMissingArtefacts) {
  PointCloud cloud = SphereOnBackground({}, 12.5, 0.01, false);
  const PlaneResult p = EvaluatePlane(cloud);
  ASSERT_TRUE(p.ok()) << p.BriefReport();
  EXPECT_GT(p.F_mm, 0.04);
  EXPECT_LT(p.F_mm, 0.1);
  // No sphere there; and an empty cloud.
  EXPECT_FALSE(EvaluateSphere(cloud, 25.0).ok());
  EXPECT_EQ(EvaluateSphere(PointCloud(), 25.0).status, VdiStatus::kTooFewPoints);
  EXPECT_EQ(EvaluatePlane(PointCloud()).status, VdiStatus::kTooFewPoints);
}

}  // namespace
}  // namespace fringe::eval
