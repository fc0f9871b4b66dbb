#include "fringe/registration/free_space.h"

#include <gtest/gtest.h>

#include "fringe/util/error.h"

namespace fringe::registration {
namespace {

// A pinhole grid (f = 200 px) seeing a wall at z = 300 mm across its whole field.
OrganizedPointCloud Wall(double z) {
  OrganizedPointCloud g(120, 100);
  for (int r = 0; r < g.height; ++r) {
    for (int c = 0; c < g.width; ++c) {
      g.cloud.points[g.index(c, r)] =
          Eigen::Vector3d((c - 60) / 200.0 * z, (r - 50) / 200.0 * z, z);
      g.valid[g.index(c, r)] = 1;
    }
  }
  return g;
}

// Points of a 40 x 40 mm square at depth z, in the wall camera's frame.
PointCloud Square(double z) {
  PointCloud c;
  for (double x = -20; x <= 20; x += 1) {
    for (double y = -20; y <= 20; y += 1) c.points.emplace_back(x, y, z);
  }
  return c;
}

TEST(CheckFreeSpace, PointsInFrontOfTheSeenSurfaceAreInItsFreeSpace) {
  const OrganizedPointCloud wall = Wall(300);
  const PointCloud target = wall.Compact();
  const ViewGrid grid = IndexViewGrid(wall);
  ASSERT_TRUE(grid.projection.fitted());
  // On the wall: seen, not in front. 20 mm in front: all in free space. 20 mm behind: hidden by
  // the wall, no contradiction. The on-wall square given in a frame 20 mm back and moved by the
  // pose: the pose is applied.
  const Rigid3d identity;
  const Rigid3d forward(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 20));
  const auto on = CheckFreeSpace(Square(300), target, grid, {identity, forward}, 1000, 0.5, 1);
  ASSERT_EQ(on.size(), 2u);
  EXPECT_GT(on[0].projected, 900);
  EXPECT_EQ(on[0].in_front, 0);
  EXPECT_DOUBLE_EQ(on[1].fraction(), 0.0);  // moved 20 mm back: behind the wall
  const auto front = CheckFreeSpace(Square(280), target, grid, {identity, forward}, 1000, 0.5, 1);
  EXPECT_GT(front[0].projected, 900);
  EXPECT_DOUBLE_EQ(front[0].fraction(), 1.0);
  EXPECT_DOUBLE_EQ(front[1].fraction(), 0.0);  // moved onto the wall
  // Outside the grid's field: no information.
  PointCloud aside;
  aside.points.emplace_back(1000, 0, 300);
  EXPECT_EQ(CheckFreeSpace(aside, target, grid, {identity}, 10, 0.5, 1)[0].projected, 0);
  // A grid that does not fit the cloud.
  PointCloud fewer = target;
  fewer.points.pop_back();
  EXPECT_THROW(CheckFreeSpace(Square(300), fewer, grid, {identity}, 10, 0.5, 1), Error);
}

}  // namespace
}  // namespace fringe::registration
