#include "fringe/geometry/rigid3.h"

#include <gtest/gtest.h>

#include "fringe/util/random.h"

namespace fringe {
namespace {

constexpr double kTol = 1e-12;

Rigid3d RandomRigid(util::Rng& rng) {
  std::normal_distribution<double> n(0, 1);
  Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
  return Rigid3d(q.normalized(), Eigen::Vector3d(n(rng), n(rng), n(rng)) * 100);
}

TEST(Rigid3d, InverseComposesToIdentity) {
  auto& rng = util::GlobalRng();
  for (int i = 0; i < 100; ++i) {
    const Rigid3d b_from_a = RandomRigid(rng);
    const Rigid3d id = b_from_a.Inverse() * b_from_a;
    EXPECT_LT(id.AngleRad(), 1e-7);
    EXPECT_LT(id.translation().norm(), 1e-12 * 1000);
  }
}

TEST(Rigid3d, CompositionMatchesSequentialApplication) {
  auto& rng = util::GlobalRng();
  for (int i = 0; i < 100; ++i) {
    const Rigid3d b_from_a = RandomRigid(rng), c_from_b = RandomRigid(rng);
    const Eigen::Vector3d p_in_a(1.5, -2.0, 300.0);
    const Eigen::Vector3d p_in_c = c_from_b * (b_from_a * p_in_a);
    EXPECT_LT((((c_from_b * b_from_a) * p_in_a) - p_in_c).norm(), 1e-9);
  }
}

TEST(Rigid3d, MatrixRoundTrip) {
  const Rigid3d t = RandomRigid(util::GlobalRng());
  const Rigid3d u = Rigid3d::FromMatrix(t.ToMatrix3x4());
  EXPECT_LT((t.ToMatrix4() - u.ToMatrix4()).norm(), 1e-12);
  EXPECT_NEAR(t.rotation_matrix().determinant(), 1.0, kTol);
}

TEST(Rigid3d, AngleOfAxisAngle) {
  for (double a : {0.0, 1e-9, 0.1, 1.0, 3.0}) {
    EXPECT_NEAR(Rigid3d::FromAxisAngle({0, 1, 1}, a).AngleRad(), a, 1e-12) << a;
  }
}

TEST(Rigid3d, DifferenceIsZeroForEqual) {
  const Rigid3d t = RandomRigid(util::GlobalRng());
  const RigidDifference d = Difference(t, t);
  EXPECT_LT(d.angle_rad, 1e-7);
  EXPECT_EQ(d.translation_mm, 0.0);
}

}  // namespace
}  // namespace fringe
