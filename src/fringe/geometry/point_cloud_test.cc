#include "fringe/geometry/point_cloud.h"

#include <gtest/gtest.h>

#include "fringe/util/error.h"

namespace fringe {
namespace {

TEST(OrganizedPointCloud, CompactKeepsValidInGridOrder) {
  OrganizedPointCloud grid(4, 3, true, true, true);
  EXPECT_EQ(grid.NumValid(), 0u);
  grid.cloud.points[grid.index(1, 2)] = {1, 2, 3};
  grid.valid[grid.index(1, 2)] = 1;
  grid.cloud.points[grid.index(3, 0)] = {4, 5, 6};
  grid.valid[grid.index(3, 0)] = 1;
  grid.CheckConsistent();
  const PointCloud c = grid.Compact();
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.points[0], Eigen::Vector3d(4, 5, 6));
  EXPECT_EQ(c.points[1], Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(c.normals.size(), 2u);
  EXPECT_EQ(c.quality.size(), 2u);
}

TEST(PointCloud, InconsistentAttributesThrow) {
  PointCloud c;
  c.points.resize(3);
  c.quality.resize(2);
  EXPECT_THROW(c.CheckConsistent(), Error);
}

}  // namespace
}  // namespace fringe
