#include "fringe/geometry/align.h"

#include <gtest/gtest.h>

#include "fringe/util/error.h"
#include "fringe/util/random.h"

namespace fringe {
namespace {

constexpr double kExactTolMm = 1e-9;
constexpr double kExactTolRad = 1e-9;

TEST(AlignRigid, RecoversRandomMotionsExactly) {
  auto& rng = util::GlobalRng();
  std::normal_distribution<double> n(0, 1);
  for (int trial = 0; trial < 50; ++trial) {
    const Rigid3d b_from_a(Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized(),
                           Eigen::Vector3d(n(rng), n(rng), n(rng)) * 200);
    std::vector<Eigen::Vector3d> a, b;
    const int count = 3 + trial;
    for (int i = 0; i < count; ++i) {
      a.emplace_back(n(rng) * 50, n(rng) * 50, 500 + n(rng) * 50);
      b.push_back(b_from_a * a.back());
    }
    const RigidAlignment r = AlignRigid(a, b);
    ASSERT_TRUE(r.ok()) << r.message;
    const RigidDifference d = Difference(r.b_from_a, b_from_a);
    EXPECT_LT(d.angle_rad, kExactTolRad);
    EXPECT_LT(d.translation_mm, kExactTolMm * 1000);
    EXPECT_LT(r.rms_mm, kExactTolMm * 100);
  }
}

TEST(AlignRigid, WeightsSuppressOutlier) {
  auto& rng = util::GlobalRng();
  std::normal_distribution<double> n(0, 1);
  const Rigid3d b_from_a = Rigid3d::FromAxisAngle({1, 2, 3}, 0.7, {10, -20, 30});
  std::vector<Eigen::Vector3d> a, b;
  std::vector<double> w;
  for (int i = 0; i < 20; ++i) {
    a.emplace_back(n(rng) * 50, n(rng) * 50, n(rng) * 50);
    b.push_back(b_from_a * a.back());
    w.push_back(1.0);
  }
  b[5] += Eigen::Vector3d(30, 0, 0);  // gross outlier
  w[5] = 0.0;
  const RigidAlignment r = AlignRigid(a, b, w);
  ASSERT_TRUE(r.ok());
  EXPECT_LT(Difference(r.b_from_a, b_from_a).translation_mm, 1e-9);
  EXPECT_EQ(r.num_points, 19);
  const RigidAlignment unweighted = AlignRigid(a, b);
  EXPECT_GT(Difference(unweighted.b_from_a, b_from_a).translation_mm, 0.1);
}

TEST(AlignRigid, TooFewPoints) {
  std::vector<Eigen::Vector3d> a = {{0, 0, 0}, {1, 0, 0}};
  const RigidAlignment r = AlignRigid(a, a);
  EXPECT_EQ(r.status, RigidAlignment::Status::kTooFewPoints);
  EXPECT_FALSE(r.ok());
}

TEST(AlignRigid, CollinearIsDegenerate) {
  std::vector<Eigen::Vector3d> a = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {5, 5, 5}};
  const RigidAlignment r = AlignRigid(a, a);
  EXPECT_EQ(r.status, RigidAlignment::Status::kDegenerate) << r.message;
}

TEST(AlignRigid, SizeMismatchThrows) {
  std::vector<Eigen::Vector3d> a(4, Eigen::Vector3d::Zero()), b(3, Eigen::Vector3d::Zero());
  EXPECT_THROW(AlignRigid(a, b), Error);
}

}  // namespace
}  // namespace fringe
