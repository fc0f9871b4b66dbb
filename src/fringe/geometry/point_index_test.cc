#include "fringe/geometry/point_index.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "fringe/util/error.h"

namespace fringe {
namespace {

TEST(PointIndex, NearestAgreesWithBruteForce) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-50, 50);
  std::vector<Eigen::Vector3d> points(2000);
  for (auto& p : points) p = {u(rng), u(rng), u(rng)};
  const PointIndex index(points);
  ASSERT_EQ(index.size(), points.size());
  std::vector<size_t> ids;
  std::vector<double> d2;
  for (int q = 0; q < 200; ++q) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    std::vector<double> all(points.size());
    for (size_t i = 0; i < points.size(); ++i) all[i] = (points[i] - p).squaredNorm();
    std::vector<double> sorted = all;
    std::sort(sorted.begin(), sorted.end());
    const auto [nearest, nearest_d2] = index.Nearest(p);
    EXPECT_DOUBLE_EQ(nearest_d2, sorted[0]);
    EXPECT_DOUBLE_EQ(all[nearest], sorted[0]);
    ASSERT_EQ(index.Nearest(p, 5, &ids, &d2), 5u);
    for (size_t k = 0; k < 5; ++k) {
      EXPECT_DOUBLE_EQ(d2[k], sorted[k]);
      EXPECT_DOUBLE_EQ(all[ids[k]], sorted[k]);
    }
  }
}

TEST(PointIndex, FewerPointsThanAskedAndNoPoints) {
  const PointIndex two({{0, 0, 0}, {1, 0, 0}});
  std::vector<size_t> ids;
  std::vector<double> d2;
  EXPECT_EQ(two.Nearest({0.9, 0, 0}, 5, &ids, &d2), 2u);
  EXPECT_EQ(ids, (std::vector<size_t>{1, 0}));
  const PointIndex none({});
  EXPECT_EQ(none.Nearest({0, 0, 0}, 3, &ids, &d2), 0u);
  EXPECT_TRUE(ids.empty());
  EXPECT_THROW(none.Nearest({0, 0, 0}), Error);
}

// The radius-bounded query agrees with brute force, inside and outside the radius, and an index
// over the caller's points (no copy) gives the same answers as one that owns a copy.
TEST(PointIndex, NearestWithinARadiusOverBorrowedPoints) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-10, 10);
  std::vector<Eigen::Vector3d> points(2000);
  for (auto& p : points) p = {u(rng), u(rng), 0.1 * u(rng)};
  const PointIndex borrowed(points.data(), points.size());
  const PointIndex owned(points);
  ASSERT_EQ(borrowed.size(), points.size());
  EXPECT_EQ(&borrowed.point(7), &points[7]);
  int inside = 0, outside = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    const double radius_sq = 0.25;
    double best = radius_sq;
    int64_t expected = -1;
    for (size_t i = 0; i < points.size(); ++i) {
      const double d2 = (points[i] - p).squaredNorm();
      if (d2 < best) best = d2, expected = static_cast<int64_t>(i);
    }
    EXPECT_EQ(borrowed.NearestWithin(p, radius_sq), expected);
    EXPECT_EQ(owned.NearestWithin(p, radius_sq), expected);
    (expected < 0 ? outside : inside) += 1;
    EXPECT_EQ(borrowed.Nearest(p), owned.Nearest(p));
  }
  EXPECT_GT(inside, 10);  // both outcomes are exercised
  EXPECT_GT(outside, 10);
}

}  // namespace
}  // namespace fringe
