#include "fringe/fusion/tiles.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "fringe/geometry/point_index.h"
#include "fringe/sim/poses.h"
#include "fringe/sim/renderer.h"
#include "fringe/sim/scene.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/testing/fusion_views.h"
#include "fringe/util/error.h"

namespace fringe::fusion {
namespace {

namespace fs = std::filesystem;
using testing::TruthView;

// The tolerance tiles.h states: the tiled result has the whole-at-once result's number of points
// within kMaxCountDifference, at least kMinEqualFraction of its points lie within kEqualMm of a
// whole-at-once point, and 99 % within kP99Mm (and the other way round). What differs are the
// per-call statistics of fusion (tiles.h) and the pieces' float storage, which move some points
// by far less than the 0.03 mm noise.
constexpr double kMaxCountDifference = 0.005;
constexpr double kMinEqualFraction = 0.9;
constexpr double kEqualMm = 1e-3;
constexpr double kP99Mm = 0.01;
// Overlap flags per slot: the same for this fraction of the whole-at-once flags.
constexpr double kMinEqualOverlapFraction = 0.99;

// Distances of a's points to their nearest point of b, sorted.
std::vector<double> SortedDistances(const PointCloud& a, const PointCloud& b) {
  const PointIndex index(b.points);
  std::vector<double> d;
  for (const Eigen::Vector3d& p : a.points) d.push_back(std::sqrt(index.Nearest(p).second));
  std::sort(d.begin(), d.end());
  return d;
}

void ExpectEqualWithinTolerance(const PointCloud& a, const PointCloud& b) {
  const std::vector<double> d = SortedDistances(a, b);
  ASSERT_FALSE(d.empty());
  const double equal =
      double(std::upper_bound(d.begin(), d.end(), kEqualMm) - d.begin()) / double(d.size());
  const double p99 = d[static_cast<size_t>(0.99 * double(d.size() - 1))];
  EXPECT_GE(equal, kMinEqualFraction);
  EXPECT_LE(p99, kP99Mm) << "max " << d.back();
}

// Three noisy views of a sphere (320 x 256 grids, ~0.8 mm spacing), slightly misregistered.
std::vector<FusionView> SphereViews() {
  const StereoRig rig = sim::ScaledRig(StereoRig::Reference(), 0.25);
  const sim::Renderer renderer(sim::MakeSphereScene(30), rig);
  std::vector<FusionView> views;
  for (int v = 0; v < 3; ++v) {
    const double a = 2 * M_PI * v / 3;
    const Rigid3d pose = sim::SensorPoseLookingAt(
        rig, {0, 0, 30}, Eigen::Vector3d(std::cos(a), std::sin(a), 1.2).normalized());
    const Rigid3d used(pose.rotation(),
                       pose.translation() + Eigen::Vector3d(0.01 * v, -0.01 * v, 0.02));
    views.push_back(TruthView(renderer, std::to_string(v), pose, used, 0.03, v + 1));
  }
  return views;
}

std::vector<TiledView> Describe(const std::vector<FusionView>& views) {
  std::vector<TiledView> out;
  for (const FusionView& v : views) {
    const OrganizedPointCloud* grid = &v.cloud;
    out.push_back(
        DescribeTiledView(v.name, v.cloud, v.world_from_sensor, [grid] { return *grid; }));
  }
  return out;
}

class FusionTiles : public ::testing::Test {
 protected:
  test::TempDir scratch_;  // removed with the fixture
};

TEST_F(FusionTiles, DefaultOptionsPassCheckAndBadOptionsThrow) {
  EXPECT_NO_THROW(TileOptions().Check());
  TileOptions o;
  o.tile_size_mm = 0;
  EXPECT_THROW(o.Check(), Error);
  o = TileOptions();
  o.margin_mm = -1;
  EXPECT_THROW(o.Check(), Error);
  // Several tiles need a scratch folder.
  const std::vector<FusionView> views = SphereViews();
  o = TileOptions();
  o.tile_size_mm = 20;
  EXPECT_THROW(FuseTiled(Describe(views), FusionOptions(), o), Error);
}

TEST_F(FusionTiles, TiledFusionEqualsTheWholeAtOnceWhateverTheTileSize) {
  const std::vector<FusionView> views = SphereViews();
  const FusionResult whole = FuseViews(views, FusionOptions());
  ASSERT_EQ(whole.summary.status, FusionStatus::kOk);
  ASSERT_GT(whole.summary.clusters, 1000);
  const std::vector<TiledView> described = Describe(views);
  // One tile is FuseViews itself.
  {
    const TiledFusionResult one = FuseTiled(described, FusionOptions(), TileOptions());
    EXPECT_EQ(one.tiles.tiles, 1);
    EXPECT_EQ(one.result.fused.points, whole.fused.points);
  }
  // The sphere's box is ~60 mm: 25 mm tiles cut it 3 x 3 x 2, 40 mm 2 x 2 x 1 (margin ~19 mm).
  for (double tile_mm : {25.0, 40.0}) {
    SCOPED_TRACE(tile_mm);
    TileOptions o;
    o.tile_size_mm = tile_mm;
    o.scratch_dir = scratch_ / "pieces";
    const TiledFusionResult tiled = FuseTiled(described, FusionOptions(), o);
    ASSERT_EQ(tiled.result.summary.status, FusionStatus::kOk) << tiled.result.summary.message;
    EXPECT_GT(tiled.tiles.tiles_fused, 2);
    EXPECT_FALSE(fs::exists(o.scratch_dir));  // the pieces are gone
    const PointCloud& t = tiled.result.fused;
    EXPECT_EQ(t.size(), tiled.result.support.size());
    EXPECT_EQ(t.size(), tiled.result.view.size());
    EXPECT_NEAR(double(t.size()) / double(whole.fused.size()), 1.0, kMaxCountDifference);
    ExpectEqualWithinTolerance(t, whole.fused);
    ExpectEqualWithinTolerance(whole.fused, t);
    // Overlap flags per slot as the whole at once sets them (the same tolerance).
    int64_t same = 0, flagged = 0;
    for (size_t v = 0; v < views.size(); ++v) {
      for (size_t i = 0; i < views[v].cloud.valid.size(); ++i) {
        if (!views[v].cloud.valid[i]) continue;
        flagged += whole.overlap[v][i];
        same += whole.overlap[v][i] && tiled.result.overlap[v][i];
      }
    }
    EXPECT_GE(double(same) / double(flagged), kMinEqualOverlapFraction);
    EXPECT_NEAR(double(tiled.result.summary.overlap_points) / double(flagged), 1.0,
                kMaxCountDifference);
  }
}

}  // namespace
}  // namespace fringe::fusion
