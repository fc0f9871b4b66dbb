// bench_pipeline: the whole scanner on the demo scan (issue 13).
//
// 1. Simulate the demo part with its sticky markers: N views around it (default 8) x 2 cameras
//    x 1280x1024 x 12 images (heterodyne-4x3, patterns pre-compensated for gamma 2.2,
//    sigma = 1.5 DN), plus 15 calibration board poses, written as PNG files (simulate_s).
// 2. pipeline::RunScan on that folder: calibrate from the board images (calibrate_s, reported
//    apart: a rig is calibrated once, not per scan), then from the PNGs on disk every view
//    read (read_s), decoded (decode_s), matched/triangulated/normals (reconstruct_s), markers
//    measured, written, the report (report_s); total_s = the scan's wall time without
//    calibration. Stage times other than total_s are sums over the views running in parallel.
// 3. Accuracy against the simulator's truth: every view's points placed by its TRUE pose, RMS
//    distance to the truth mesh (single_view_rms_mm, all points of all views).
//
// Registration, fusion and meshing are not part of the scan yet: register_s, fuse_s, mesh_s,
// pose errors and fused_rms_mm are printed as null.
//
// Usage: bench_pipeline [--json] [--views 8] [--work DIR] [--rig-scale 1] [--keep]
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "fringe/eval/deviation.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/mesh_io.h"
#include "fringe/io/ply.h"
#include "fringe/pipeline/scan.h"
#include "fringe/sim/scan.h"
#include "fringe/util/log.h"
#include "fringe/util/memory.h"
#include "fringe/util/timer.h"

namespace fs = std::filesystem;
using nlohmann::json;

int main(int argc, char** argv) {
  CLI::App app{"bench_pipeline: the whole scanner on the simulated demo scan"};
  bool as_json = false, keep = false;
  int views = 8;
  double rig_scale = 1.0;
  std::string work = "bench_pipeline_work";
  app.add_flag("--json", as_json, "Print one JSON object");
  app.add_option("--views", views, "Views around the part")->check(CLI::Range(1, 64));
  app.add_option("--rig-scale", rig_scale, "Camera/projector resolution scale (1: 1280x1024)")
      ->check(CLI::Range(0.1, 1.0));
  app.add_option("--work", work, "Work folder (scan and result are written below it)");
  app.add_flag("--keep", keep, "Keep the work folder");
  CLI11_PARSE(app, argc, argv);
  using namespace fringe;
  try {
    if (!as_json) util::SetVerbosity(util::Verbosity::kNormal);
    const fs::path dir = work;
    fs::create_directories(dir);
    const StereoRig rig = sim::ScaledRig(StereoRig::Reference(), rig_scale);
    sim::ScanOptions so;
    so.scene = "demo";
    so.views = views;
    so.precompensate_gamma = 2.2;
    so.calibration_images = 15;
    util::Timer timer;
    sim::SimulateScan(rig, so, dir / "scan");
    const double simulate_s = timer.ElapsedSeconds();

    const pipeline::ScanSummary s = pipeline::RunScan(dir / "scan", dir / "out");

    // Accuracy against the truth: each view placed by its true pose.
    const json poses = io::ReadJson(dir / "scan" / "truth" / "poses.json");
    const eval::MeshDistance distance(io::ReadMesh(dir / "scan" / "truth" / "scene.ply"));
    double sum_sq = 0;
    int64_t n = 0;
    for (size_t v = 0; v < s.views.size(); ++v) {
      if (!s.views[v].ok) continue;
      PointCloud world =
          io::ReadOrganizedPly(dir / "out" / "views" / (s.views[v].name + ".ply")).Compact();
      const Rigid3d world_from_sensor =
          io::RigidFromJson(poses.at("views").at(v).at("world_from_sensor"), "poses.json");
      for (auto& p : world.points) p = world_from_sensor * p;
      const eval::DeviationStats dev = eval::DeviationFromMesh(world, distance);
      sum_sq += dev.rms_mm * dev.rms_mm * static_cast<double>(dev.points);
      n += dev.points;
    }
    const double single_view_rms_mm = n ? std::sqrt(sum_sq / static_cast<double>(n)) : NAN;

    json j{{"views", s.views_ok},
           {"image_width", rig.left.width},
           {"image_height", rig.left.height},
           {"points", s.points},
           {"simulate_s", simulate_s},
           {"calibrate_s", s.calibrate_s},
           {"total_s", s.total_s},
           {"read_s", s.read_s},
           {"decode_s", s.decode_s},
           {"reconstruct_s", s.reconstruct_s},
           {"markers_s", s.markers_s},
           {"views_s", s.views_s},
           {"register_s", nullptr},
           {"fuse_s", nullptr},
           {"mesh_s", nullptr},
           {"report_s", s.report_s},
           {"peak_mem_gib", util::PeakMemoryGiB()},
           {"calibration_rms_left_px", s.calibration_rms_left_px},
           {"pose_rot_err_deg", nullptr},
           {"pose_trans_err_mm", nullptr},
           {"fused_rms_mm", nullptr},
           {"single_view_rms_mm", single_view_rms_mm}};
    if (as_json) {
      std::cout << j.dump() << "\n";
    } else {
      std::cout << s.BriefReport() << "\n";
      for (auto it = j.begin(); it != j.end(); ++it) {
        std::printf("%-24s %s\n", it.key().c_str(), it.value().dump().c_str());
      }
    }
    if (!keep) fs::remove_all(dir);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_pipeline: %s\n", e.what());
    return 1;
  }
  return 0;
}
