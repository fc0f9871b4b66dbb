#include "fringe/sim/demo_part.h"

#include <gtest/gtest.h>

#include <cmath>

#include "fringe/sim/markers.h"
#include "fringe/sim/poses.h"
#include "fringe/sim/ray_caster.h"
#include "fringe/sim/renderer.h"
#include "fringe/util/error.h"

namespace fringe::sim {
namespace {

// The demo part is costly to build; share one across this file's tests.
const Scene& DemoScene() {
  static const Scene scene = MakeDemoPart();
  return scene;
}

TEST(DemoPart, OptionDefaultsPassCheck) {
  EXPECT_NO_THROW(DemoPartOptions().Check());
  EXPECT_NO_THROW(MarkerOptions().Check());
  MarkerOptions bad;
  bad.inner_diameter_mm = 6;
  EXPECT_THROW(bad.Check(), Error);
}

TEST(DemoPart, SizeAndFeatures) {
  const Scene& scene = DemoScene();
  const SceneObject* part = scene.FindObject("part");
  ASSERT_NE(part, nullptr);
  ASSERT_NE(scene.FindObject("base_plate"), nullptr);
  Eigen::Vector3d lo, hi;
  part->mesh.Bounds(&lo, &hi);
  const DemoPartOptions opt;
  EXPECT_NEAR(hi.x() - lo.x(), 150, 2 * opt.grid_mm + 1e-9);
  EXPECT_NEAR(hi.y() - lo.y(), 100, 2 * opt.grid_mm + 1e-9);
  EXPECT_NEAR(hi.z(), 60, 1e-9);
  EXPECT_NEAR(lo.z(), 0, 1e-9);
  // Fine detail: engraving and ribs are present in the height function.
  EXPECT_EQ(DemoPartHeight(-60, 0), 28);
  EXPECT_NEAR(DemoPartHeight(44.3, 0), 20.5, 1e-12);
  EXPECT_NEAR(DemoPartHeight(45.0, 0), 20.0, 1e-12);
  EXPECT_EQ(DemoPartHeight(10, 20), 35);  // bore
  EXPECT_EQ(DemoPartHeight(100, 0), 0);   // off the part
}

TEST(DemoPart, MarkersLieOnTheSurfaceAndDoNotOverlap) {
  const Scene& scene = DemoScene();
  const DemoPartOptions opt;
  ASSERT_EQ(static_cast<int>(scene.markers().size()), opt.markers_on_part + opt.markers_on_plate);
  Scene geometry = scene;
  geometry.ClearMarkers();
  const RayCaster caster(geometry);
  constexpr double kOnSurfaceMm = 1e-6;
  int on_part = 0;
  for (const Marker& m : scene.markers()) {
    const auto hit = caster.Cast(m.centre_in_world + 5 * m.normal_in_world, -m.normal_in_world);
    ASSERT_TRUE(hit.has_value());
    EXPECT_NEAR(hit->t, 5.0, kOnSurfaceMm);
    EXPECT_GT(m.normal_in_world.z(), 0.5);
    if (geometry.objects()[hit->object].name == "part") ++on_part;
    EXPECT_NEAR(m.outer_radius_mm, 2.5, 1e-12);
    for (const Marker& other : scene.markers()) {
      if (other.id == m.id) continue;
      EXPECT_GE((other.centre_in_world - m.centre_in_world).norm(),
                m.outer_radius_mm + other.outer_radius_mm);
    }
  }
  EXPECT_EQ(on_part, opt.markers_on_part);
  // Seeded: the same options give the same markers.
  DemoPartOptions fewer;
  fewer.markers_on_part = 3;
  fewer.markers_on_plate = 0;
  const Scene again = MakeDemoPart(fewer);
  ASSERT_EQ(again.markers().size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(again.markers()[i].centre_in_world, scene.markers()[i].centre_in_world);
  }
}

// Each marker visible in a view projects inside its rendered white disk.
TEST(DemoPart, VisibleMarkersProjectInsideTheirRenderedDisk) {
  const StereoRig rig = ScaledRig(StereoRig::Reference(), 0.5);
  RenderOptions opt;
  opt.sensor.noise = false;
  opt.sensor.float_output = true;
  const Renderer renderer(DemoScene(), rig, opt);
  const cv::Mat white(rig.projector->height, rig.projector->width, CV_8U, cv::Scalar(255));
  const Rigid3d pose =
      SensorPoseLookingAt(rig, Eigen::Vector3d(0, 0, 20), Eigen::Vector3d(0, -0.5, 1).normalized());
  const ViewImages view = renderer.RenderView(pose, {white});
  constexpr double kCentroidTolerancePx = 0.3;
  int checked = 0;
  for (const MarkerObservation& o : view.markers) {
    for (int cam = 0; cam < 2; ++cam) {
      const bool visible = cam == 0 ? o.visible_left : o.visible_right;
      if (!visible) continue;
      const Eigen::Vector2d px = cam == 0 ? o.left_px : o.right_px;
      const cv::Mat& img = (cam == 0 ? view.left : view.right).images[0];
      const CameraTruth& truth = (cam == 0 ? view.left : view.right).truth;
      const int r0 = static_cast<int>(std::lround(px.y())),
                c0 = static_cast<int>(std::lround(px.x()));
      if (r0 < 8 || c0 < 8 || r0 >= img.rows - 8 || c0 >= img.cols - 8) continue;
      if (!truth.valid.at<uint8_t>(r0, c0)) continue;  // in projector shadow: dark
      // The white disk (3 mm) is ~7 px across: the centre pixel is bright, and the centroid of
      // the bright pixels on the sticker (pixels whose true surface point lies within the ring)
      // is the projected centre.
      const Rigid3d world_from_cam = cam == 0 ? pose : pose * rig.right_from_left.Inverse();
      const Marker& m = DemoScene().markers()[o.id];
      auto on_sticker = [&](int r, int c) {
        const cv::Vec3d p = truth.points.at<cv::Vec3d>(r, c);
        return std::isfinite(p[0]) &&
               (world_from_cam * Eigen::Vector3d(p[0], p[1], p[2]) - m.centre_in_world).norm() <
                   m.outer_radius_mm;
      };
      double peak = 0;
      for (int r = r0 - 7; r <= r0 + 7; ++r) {
        for (int c = c0 - 7; c <= c0 + 7; ++c) {
          if (on_sticker(r, c)) peak = std::max(peak, double(img.at<float>(r, c)));
        }
      }
      double sw = 0, sx = 0, sy = 0;
      for (int r = r0 - 7; r <= r0 + 7; ++r) {
        for (int c = c0 - 7; c <= c0 + 7; ++c) {
          if (!on_sticker(r, c)) continue;
          const double w = std::max(0.0, img.at<float>(r, c) - 0.5 * peak);
          sw += w;
          sx += w * c;
          sy += w * r;
        }
      }
      EXPECT_GT(img.at<float>(r0, c0), 0.8 * peak) << "marker " << o.id << " cam " << cam;
      EXPECT_LT((Eigen::Vector2d(sx / sw, sy / sw) - px).norm(), kCentroidTolerancePx)
          << "marker " << o.id << " cam " << cam;
      ++checked;
    }
  }
  EXPECT_GT(checked, 20);
}

}  // namespace
}  // namespace fringe::sim
