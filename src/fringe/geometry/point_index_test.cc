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

}  // namespace
}  // namespace fringe
