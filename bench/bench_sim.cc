// bench_sim: the virtual scanner's speed on the demo part.
//
// Times building the demo part (mesh + markers), building the renderer (Embree BVH, marker
// index), rendering one view (2 cameras x 1280x1024, 3x3 supersampling, the 12 images of the
// "heterodyne-4x3" scheme, noise on) and one calibration board image (1280x1024). Peer: Open3D's
// RaycastingScene (also Embree) casting the same number of primary rays on the same mesh, when
// Open3D is available; the ratio compares our whole view (primary + shadow rays + shading of 12
// patterns + sensor model) with its primary rays alone.
//
//   build/bench/bench_sim [--json] [--supersampling N]
#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <iostream>
#include <string>

#include "fringe/geometry/calibration_target.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/sim/board.h"
#include "fringe/sim/demo_part.h"
#include "fringe/sim/poses.h"
#include "fringe/sim/renderer.h"
#include "fringe/util/timer.h"

#ifdef FRINGE_BENCH_HAVE_OPEN3D
#include <open3d/core/Tensor.h>
#include <open3d/t/geometry/RaycastingScene.h>
#endif

using namespace fringe;

namespace {

#ifdef FRINGE_BENCH_HAVE_OPEN3D
// Casts the primary rays of both cameras (n x n per pixel) with Open3D; returns seconds.
double Open3dPrimaryRays(const sim::Scene& scene, const StereoRig& rig,
                         const Rigid3d& world_from_sensor, int n) {
  const TriangleMesh mesh = scene.CombinedMesh();
  open3d::core::Tensor vertices({static_cast<int64_t>(mesh.vertices.size()), 3},
                                open3d::core::Float32);
  open3d::core::Tensor triangles({static_cast<int64_t>(mesh.triangles.size()), 3},
                                 open3d::core::UInt32);
  auto* v = vertices.GetDataPtr<float>();
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    for (int d = 0; d < 3; ++d) v[3 * i + d] = static_cast<float>(mesh.vertices[i][d]);
  }
  auto* t = triangles.GetDataPtr<uint32_t>();
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    for (int d = 0; d < 3; ++d) t[3 * i + d] = static_cast<uint32_t>(mesh.triangles[i][d]);
  }
  open3d::t::geometry::RaycastingScene o3d;
  o3d.AddTriangles(vertices, triangles);
  double seconds = 0;
  for (int cam = 0; cam < 2; ++cam) {
    const CameraModel& c = cam == 0 ? rig.left : rig.right;
    const Rigid3d world_from_cam =
        cam == 0 ? world_from_sensor : world_from_sensor * rig.right_from_left.Inverse();
    const int64_t count = static_cast<int64_t>(c.width) * c.height * n * n;
    open3d::core::Tensor rays({count, 6}, open3d::core::Float32);
    auto* r = rays.GetDataPtr<float>();
    const Eigen::Vector3d o = world_from_cam.translation();
    int64_t k = 0;
    for (int y = 0; y < c.height; ++y) {
      for (int sj = 0; sj < n; ++sj) {
        for (int x = 0; x < c.width; ++x) {
          for (int si = 0; si < n; ++si, ++k) {
            const Eigen::Vector3d d = world_from_cam.RotateDirection(
                c.Ray(Eigen::Vector2d(x + (si + 0.5) / n - 0.5, y + (sj + 0.5) / n - 0.5)));
            for (int q = 0; q < 3; ++q) {
              r[6 * k + q] = static_cast<float>(o[q]);
              r[6 * k + 3 + q] = static_cast<float>(d[q]);
            }
          }
        }
      }
    }
    util::Timer timer;
    auto result = o3d.CastRays(rays);
    seconds += timer.ElapsedSeconds();
  }
  return seconds;
}
#endif

}  // namespace

int main(int argc, char** argv) {
  bool json = false;
  bool peer = true;
  int n = 3;
  bool no_peer = false;
  CLI::App app("bench_sim: virtual scanner speed, Open3D ray casting as a peer");
  app.add_flag("--json", json, "Print one JSON object");
  app.add_flag("--no-peer", no_peer, "Skip the Open3D peer");
  app.add_option("--supersampling", n, "Samples per pixel side")
      ->check(CLI::Range(1, 16))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  peer = !no_peer;
  const StereoRig rig = StereoRig::Reference();
  util::Timer timer;
  const sim::Scene scene = sim::MakeDemoPart();
  const double scene_s = timer.ElapsedSeconds();
  sim::RenderOptions options;
  options.sensor.supersampling = n;
  timer.Restart();
  const sim::Renderer renderer(scene, rig, options);
  const double setup_s = timer.ElapsedSeconds();
  const phase::PatternScheme scheme =
      phase::MakeScheme("heterodyne-4x3", rig.projector->width, rig.projector->height);
  const std::vector<cv::Mat> patterns = phase::GeneratePatterns(scheme);
  const Rigid3d pose = sim::SensorPoseLookingAt(rig, Eigen::Vector3d(0, 0, 25),
                                                Eigen::Vector3d(0.3, -0.6, 1).normalized());
  timer.Restart();
  const std::clock_t cpu_start = std::clock();
  const sim::ViewImages view = renderer.RenderView(pose, patterns, 0);
  const double view_s = timer.ElapsedSeconds();
  // CPU time of all threads: the machine is shared, so wall time alone can mislead.
  const double view_cpu_s = double(std::clock() - cpu_start) / CLOCKS_PER_SEC;
  const double truth_valid =
      cv::countNonZero(view.left.truth.valid) / double(rig.left.width * rig.left.height);

  const CalibrationTarget target;
  sim::BoardPoseOptions bpo;
  bpo.count = 1;
  const auto board_poses = sim::GenerateBoardPoses(rig, target, bpo);
  timer.Restart();
  const sim::BoardImage board = sim::RenderBoardImage(rig.left, target, board_poses[0]);
  const double board_s = timer.ElapsedSeconds();

  double peer_s = -1;
#ifdef FRINGE_BENCH_HAVE_OPEN3D
  if (peer) peer_s = Open3dPrimaryRays(scene, rig, pose, n);
#endif
  const double rays = 2.0 * rig.left.width * rig.left.height * n * n;
  if (json) {
    std::printf(
        "{\"benchmark\": \"bench_sim\", \"scene\": \"demo\", \"triangles\": %zu, \"markers\": %zu, "
        "\"cameras\": 2, \"width\": %d, \"height\": %d, \"patterns\": %zu, \"supersampling\": %d, "
        "\"scene_build_s\": %.3f, \"renderer_setup_s\": %.3f, \"view_render_s\": %.3f, "
        "\"view_render_cpu_s\": %.3f, "
        "\"primary_rays\": %.0f, \"valid_fraction_left\": %.3f, \"board_image_s\": %.3f, "
        "\"peer\": \"open3d_raycasting_primary_rays\", \"peer_s\": %.3f, \"ratio_view_over_peer\": "
        "%.3f}\n",
        scene.NumTriangles(), scene.markers().size(), rig.left.width, rig.left.height,
        patterns.size(), n, scene_s, setup_s, view_s, view_cpu_s, rays, truth_valid, board_s,
        peer_s, peer_s > 0 ? view_s / peer_s : -1.0);
  } else {
    std::printf(
        "bench_sim: demo part (%zu triangles, %zu markers), 2 x %dx%d, %zu patterns, %dx%d "
        "supersampling\n",
        scene.NumTriangles(), scene.markers().size(), rig.left.width, rig.left.height,
        patterns.size(), n, n);
    std::printf("  %-44s %8.3f s\n", "build demo part (mesh + markers)", scene_s);
    std::printf("  %-44s %8.3f s\n", "renderer setup (Embree BVH, marker index)", setup_s);
    std::printf("  %-44s %8.3f s   (CPU %.3f s, %.1f M primary rays, %.0f%% valid)\n",
                "render one view (both cameras, all patterns)", view_s, view_cpu_s, rays / 1e6,
                100 * truth_valid);
    std::printf("  %-44s %8.3f s\n", "render one board image (1280x1024)", board_s);
    if (peer_s > 0) {
      std::printf("  %-44s %8.3f s   ratio ours/peer %.2f\n",
                  "peer: Open3D RaycastingScene, primary rays", peer_s, view_s / peer_s);
    } else {
      std::printf("  peer: Open3D not available\n");
    }
  }
  return 0;
}
