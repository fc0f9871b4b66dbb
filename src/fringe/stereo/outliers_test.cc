#include "fringe/stereo/outliers.h"

#include <gtest/gtest.h>

#include "fringe/util/error.h"

namespace fringe::stereo {
namespace {

TEST(Outliers, DefaultOptionsPassCheck) { EXPECT_NO_THROW(OutlierOptions().Check()); }

TEST(Outliers, RemovesFlyingPixelsAndSmallPatches) {
  constexpr double kFocal = 625;
  const int w = 120, h = 100;
  OrganizedPointCloud grid(w, h);
  auto set = [&](int c, int r, double z) {
    const size_t i = grid.index(c, r);
    grid.valid[i] = 1;
    grid.cloud.points[i] = Eigen::Vector3d((c - 60) * z / kFocal, (r - 50) * z / kFocal, z);
  };
  // A tilted plane over the whole grid ...
  for (int r = 0; r < h; ++r) {
    for (int c = 0; c < w; ++c) set(c, r, 500 + 0.3 * c);
  }
  // ... three flying pixels 10-20 mm off it (> 5 pixel footprints of ~0.8 mm per grid step,
  // diagonals included), and a 4x4 patch 20 mm in front.
  set(10, 10, 490);
  set(50, 70, 535);
  set(100, 30, 550);
  for (int r = 40; r < 44; ++r) {
    for (int c = 20; c < 24; ++c) set(c, r, 480);
  }
  const OutlierSummary s = RemoveOrganizedOutliers(&grid, kFocal);
  EXPECT_TRUE(s.ok()) << s.BriefReport();
  EXPECT_EQ(s.flying_pixels, 3) << s.BriefReport();
  EXPECT_EQ(s.small_components, 1);
  EXPECT_EQ(s.component_points, 16);
  EXPECT_EQ(s.kept, w * h - 19);
  EXPECT_EQ(grid.NumValid(), static_cast<size_t>(w * h - 19));
  EXPECT_FALSE(grid.valid[grid.index(10, 10)]);
  EXPECT_FALSE(grid.valid[grid.index(21, 41)]);
  EXPECT_TRUE(grid.valid[grid.index(30, 30)]);
}

TEST(Outliers, StatusForEmptyAndFullyRemovedClouds) {
  OrganizedPointCloud empty(20, 10);
  const OutlierSummary none = RemoveOrganizedOutliers(&empty, 625);
  EXPECT_EQ(none.status, OutlierStatus::kNoPoints);
  EXPECT_FALSE(none.message.empty());
  // A 3x3 patch is a component smaller than the default 50 px: everything goes.
  OrganizedPointCloud patch(20, 10);
  for (int r = 2; r < 5; ++r) {
    for (int c = 2; c < 5; ++c) {
      patch.valid[patch.index(c, r)] = 1;
      patch.cloud.points[patch.index(c, r)] = Eigen::Vector3d(c * 0.8, r * 0.8, 500);
    }
  }
  const OutlierSummary all = RemoveOrganizedOutliers(&patch, 625);
  EXPECT_EQ(all.status, OutlierStatus::kAllRemoved) << all.BriefReport();
  EXPECT_EQ(all.component_points, 9);
  EXPECT_EQ(patch.NumValid(), 0u);
  EXPECT_NE(all.BriefReport().find("all points removed"), std::string::npos);
  EXPECT_THROW(RemoveOrganizedOutliers(&patch, 0.0), Error);
}

}  // namespace
}  // namespace fringe::stereo
