// `fringe reconstruct` with one camera + projector (both fringe directions, markers) and in
// trinocular mode, on simulated views of the quarter-resolution reference rig.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "fringe/cli/run_cli_for_test.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/io/ply.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/registration/markers.h"
#include "fringe/sim/poses.h"
#include "fringe/sim/renderer.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/testing/registration_views.h"

namespace fringe {
namespace {

void WriteStack(const std::filesystem::path& dir, const phase::PatternScheme& scheme,
                const std::vector<cv::Mat>& images, bool with_manifest) {
  std::filesystem::create_directories(dir);
  const auto names = scheme.ImageNames();
  for (size_t i = 0; i < images.size(); ++i) io::WriteImage(dir / names[i], images[i]);
  if (with_manifest) phase::WriteScheme(dir / "manifest.json", scheme);
}

// RMS distance of the cloud's points to the true points of the same pixels (lit pixels whose
// 3x3 neighbourhood is lit and on one object: no mixed pixels at edges), and their count.
std::pair<double, int> RmsAgainstTruth(const OrganizedPointCloud& cloud,
                                       const sim::CameraTruth& t) {
  double ss = 0;
  int n = 0;
  for (int r = 1; r + 1 < cloud.height; ++r) {
    for (int c = 1; c + 1 < cloud.width; ++c) {
      const size_t i = cloud.index(c, r);
      if (!cloud.valid[i]) continue;
      bool interior = true;
      for (int dr = -1; dr <= 1; ++dr) {
        for (int dc = -1; dc <= 1; ++dc) {
          interior = interior && t.valid.at<uint8_t>(r + dr, c + dc) &&
                     t.object_id.at<int>(r + dr, c + dc) == t.object_id.at<int>(r, c);
        }
      }
      if (!interior) continue;
      const cv::Vec3d p = t.points.at<cv::Vec3d>(r, c);
      ss += (cloud.cloud.points[i] - Eigen::Vector3d(p[0], p[1], p[2])).squaredNorm();
      ++n;
    }
  }
  return {n ? std::sqrt(ss / n) : 0.0, n};
}

// A plane with a box and sticky markers, seen by the left camera under vertical and horizontal
// fringes (left/vertical/, left/horizontal/, each with its manifest): camera-projector mode
// triangulates both directions, and writes the markers measured in the one camera.
TEST(CameraProjectorCli, BothDirectionsAndMarkers) {
  constexpr double kRmsTolMm = 0.15;     // camera-projector bound (stereo/camera_projector_test)
  constexpr double kMarkerTolMm = 0.25;  // registration/markers_test's centre tolerance
  constexpr int kMinMarkers = 10;
  const StereoRig rig = registration::testing::SmallRig();
  sim::Scene scene = registration::testing::PlaneWithBox();
  int id = 0;
  for (double x : {-80.0, -45.0, 45.0, 80.0}) {
    for (double y : {-55.0, 0.0, 55.0}) {
      scene.AddMarker(registration::testing::MakeMarker(id++, {x, y, 0}));
    }
  }
  const phase::PatternScheme vertical =
      phase::MakeScheme("heterodyne-4x3", rig.projector->width, rig.projector->height);
  phase::PatternScheme horizontal = vertical;
  horizontal.direction = phase::FringeDirection::kHorizontal;
  horizontal.name += "-horizontal";
  sim::RenderOptions options;
  options.projector.gamma = 1.0;
  const sim::Renderer renderer(scene, rig, options);
  const Rigid3d world_from_sensor = sim::SensorPoseLookingAt(
      rig, Eigen::Vector3d(0, 0, 10), Eigen::Vector3d(0.15, -0.3, 1).normalized(), 0.2);
  const sim::ViewImages vv =
      renderer.RenderView(world_from_sensor, phase::GeneratePatterns(vertical));
  const sim::ViewImages vh =
      renderer.RenderView(world_from_sensor, phase::GeneratePatterns(horizontal));

  const test::TempDir tmp;
  const auto view = tmp / "view";
  WriteStack(view / "left" / "vertical", vertical, vv.left.images, true);
  WriteStack(view / "left" / "horizontal", horizontal, vh.left.images, true);
  StereoRig camera_projector_rig = rig;  // a camera + projector rig file: no right camera
  camera_projector_rig.right = rig.left;
  camera_projector_rig.right_from_left = Rigid3d();
  io::WriteRig(tmp / "rig.json", camera_projector_rig);

  std::string out, err;
  const std::string ply = (tmp / "cp.ply").string();
  ASSERT_EQ(cli::RunCli({"reconstruct", view.string(), "--calib", (tmp / "rig.json").string(),
                         "--out", ply, "--json"},
                        &out, &err),
            0)
      << out << err;
  const nlohmann::json j = nlohmann::json::parse(out);
  EXPECT_EQ(j.at("mode"), "camera-projector");  // auto: no right/ images
  // Both stacks were decoded (the horizontal one reported as decode_right).
  EXPECT_GT(j.at("summary").at("decode_left").at("valid").get<int>(), 20000);
  EXPECT_GT(j.at("summary").at("decode_right").at("valid").get<int>(), 20000);
  const OrganizedPointCloud cloud = io::ReadOrganizedPly(ply);
  const auto [rms_mm, compared] = RmsAgainstTruth(cloud, vv.left.truth);
  std::cout << "camera-projector, both directions: " << cloud.NumValid() << " points, RMS "
            << rms_mm << " mm over " << compared << "\n";
  EXPECT_GT(compared, 20000);
  EXPECT_LT(rms_mm, kRmsTolMm);

  // Markers beside the cloud, from the camera alone.
  const std::vector<registration::ViewMarker> markers =
      registration::ReadViewMarkers(registration::MarkersPathForCloud(ply));
  EXPECT_GE(static_cast<int>(markers.size()), kMinMarkers);
  EXPECT_EQ(j.at("markers").at("count").get<int>(), static_cast<int>(markers.size()));
  for (const auto& m : markers) {
    double best = 1e9;
    for (const auto& t : vv.markers) {
      if (t.visible_left) best = std::min(best, (t.centre_in_sensor - m.centre_in_sensor).norm());
    }
    EXPECT_LT(best, kMarkerTolMm) << "marker at " << m.left_px.transpose();
  }

  // A horizontal/ stack whose manifest says vertical is refused naming the file.
  const auto bad = tmp / "bad";
  WriteStack(bad / "left" / "vertical", vertical, vv.left.images, true);
  WriteStack(bad / "left" / "horizontal", vertical, vv.left.images, true);
  EXPECT_EQ(cli::RunCli({"reconstruct", bad.string(), "--calib", (tmp / "rig.json").string(),
                         "--out", (tmp / "bad.ply").string()},
                        &out, &err),
            1);
  EXPECT_NE(err.find("horizontal/manifest.json"), std::string::npos) << err;
  EXPECT_FALSE(std::filesystem::exists(tmp / "bad.ply"));
}

// Trinocular: the stereo view plus the left pixels the right camera cannot see.
TEST(CameraProjectorCli, TrinocularAddsLeftOnlyPoints) {
  const StereoRig rig = registration::testing::SmallRig();
  const sim::Scene scene = sim::MakeSphereScene(25.0);
  const phase::PatternScheme scheme =
      phase::MakeScheme("heterodyne-4x3", rig.projector->width, rig.projector->height);
  sim::RenderOptions options;
  options.projector.gamma = 1.0;
  const Rigid3d world_from_sensor = sim::SensorPoseLookingAt(
      rig, Eigen::Vector3d(0, 0, 25), Eigen::Vector3d(0, -0.5, 1).normalized());
  const sim::ViewImages v = sim::Renderer(scene, rig, options)
                                .RenderView(world_from_sensor, phase::GeneratePatterns(scheme));
  const test::TempDir tmp;
  WriteStack(tmp / "view" / "left", scheme, v.left.images, false);
  WriteStack(tmp / "view" / "right", scheme, v.right.images, false);
  phase::WriteScheme(tmp / "view" / "manifest.json", scheme);
  io::WriteRig(tmp / "view" / "rig.json", rig);
  std::string out, err;
  auto run = [&](const std::string& mode) {
    const std::string ply = (tmp / (mode + ".ply")).string();
    EXPECT_EQ(cli::RunCli({"reconstruct", (tmp / "view").string(), "--mode", mode, "--out", ply,
                           "--json", "--no-markers"},
                          &out, &err),
              0)
        << out << err;
    return nlohmann::json::parse(out);
  };
  const nlohmann::json stereo = run("stereo");
  const nlohmann::json tri = run("trinocular");
  EXPECT_EQ(tri.at("mode"), "trinocular");
  const int filled = tri.at("summary").at("matching").at("projector_filled").get<int>();
  EXPECT_GT(filled, 0);
  EXPECT_GT(tri.at("summary").at("points").get<int>(),
            stereo.at("summary").at("points").get<int>());
  const auto [rms_mm, compared] =
      RmsAgainstTruth(io::ReadOrganizedPly((tmp / "trinocular.ply").string()), v.left.truth);
  EXPECT_LT(rms_mm, 0.15);
  EXPECT_GT(compared, 20000);
}

}  // namespace
}  // namespace fringe
