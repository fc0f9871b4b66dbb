// bench_pipeline: the whole scanner on the demo scan (issue 13).
//
// 1. Simulate the demo part with its sticky markers: N views around it (default 8) x 2 cameras
//    x 1280x1024 x 12 images (heterodyne-4x3, patterns pre-compensated for gamma 2.2,
//    sigma = 1.5 DN), plus 15 calibration board poses, written as PNG files (simulate_s).
// 2. pipeline::RunScan on that folder: calibrate from the board images (calibrate_s, reported
//    apart: a rig is calibrated once, not per scan), then from the PNGs on disk every view
//    read (read_s), decoded (decode_s), matched/triangulated/normals (reconstruct_s), markers
//    measured, the views registered (register_s), fused (fuse_s), meshed (mesh_s), the report
//    written (report_s); total_s = the scan's wall time without calibration and without the
//    truth comparison. read_s, decode_s and reconstruct_s are sums over the views running in
//    parallel (views_s is their wall time).
// 3. Accuracy against the simulator's truth, computed by the scan itself (ScanSummary, definitions
//    in pipeline/scan.h): pose_rot_err_deg / pose_trans_err_mm (max over views, gauge removed as
//    issue 11 defines it), fused_rms_mm (all fused points) and single_view_rms_mm (the views'
//    points in the overlap regions, true poses) as issue 12 defines them, plus
//    fused_overlap_rms_mm (merged points only), single_view_all_rms_mm and mesh_rms_mm.
//
//    Every stage's process CPU time (all threads) is printed beside its wall time (*_cpu_s).
// 4. --mesh-depths 8,9,10: the scan's fused cloud (OUT/fused.ply) meshed again at each Poisson
//    depth as the scan meshes it (fusion::MeshPoisson with the scan's mesh options), each
//    compared with the truth both ways as the scan compares its own mesh
//    (pipeline::CompareMeshWithTruth): mesh_depth_<d> = {wall_s, cpu_s, poisson_s, vertices,
//    triangles, rms_mm (vertices to truth), truth_rms_mm (truth where measured to the mesh)}.
//    The depth the scan chose from the point spacing is its own mesh's (mesh_rms_mm).
// --rig FILE measures with that rig (e.g. the scan's truth/rig.json) instead of calibrating
// from the board images: what the calibration's error costs the pose and RMS figures.
//
// Usage: bench_pipeline [--json] [--views 8] [--work DIR] [--rig-scale 1] [--poisson-depth 0]
//                       [--mesh-resolution 0.75]
//                       [--keep] [--scan DIR] [--rig FILE] [--mesh-depths 8,9,10]
// --scan DIR reuses a scan folder simulated by an earlier run (--keep leaves it in WORK/scan)
// instead of simulating again (simulate_s is then null).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "fringe/eval/deviation.h"
#include "fringe/fusion/mesh.h"
#include "fringe/geometry/point_index.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/json.h"
#include "fringe/io/ply.h"
#include "fringe/phase/scheme_presets.h"
#include "fringe/pipeline/scan.h"
#include "fringe/scan/scan_folder.h"
#include "fringe/sim/scan.h"
#include "fringe/util/error.h"
#include "fringe/util/log.h"
#include "fringe/util/memory.h"
#include "fringe/util/timer.h"

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// --mesh-depths / --mesh-resolutions: the fused cloud of the result folder `out` (as the scan
// wrote it: float coordinates) meshed at each depth (or automatic depth at each wanted
// resolution) as the scan meshes it, compared with the truth both ways.
void MeshSweep(const fs::path& out, const fs::path& scan_dir,
               const fringe::Rigid3d& truth_from_world, const fringe::fusion::MeshOptions& options,
               const std::vector<int>& depths, const std::vector<double>& resolutions, json* j) {
  using namespace fringe;
  // Meshed in the scan's world frame (Poisson's cube is the cloud's bounding box there, as in
  // the scan), compared in the truth's.
  const PointCloud fused = io::ReadPly(out / "fused.ply").cloud;
  const MeshIndex truth(scan::ScanFolder::Open(scan_dir).ReadTruthMesh());
  std::vector<Eigen::Vector3d> measured;
  for (size_t i = 0; i < fused.size(); i += std::max<size_t>(1, fused.size() / 200000)) {
    measured.push_back(truth_from_world * fused.points[i]);
  }
  // Every fused point in the truth's frame: how far each vertex is from the data it stands for.
  std::vector<Eigen::Vector3d> all_measured(fused.size());
  for (size_t i = 0; i < fused.size(); ++i) all_measured[i] = truth_from_world * fused.points[i];
  const PointIndex support(std::move(all_measured));
  std::vector<std::pair<std::string, fusion::MeshOptions>> sweep;
  for (int depth : depths) {
    sweep.emplace_back("mesh_depth_" + std::to_string(depth), options);
    sweep.back().second.poisson_depth = depth;
  }
  for (double r : resolutions) {
    sweep.emplace_back("mesh_resolution_" + util::StrCat(r), options);
    sweep.back().second.poisson_depth = 0;
    sweep.back().second.resolution_mm = r;
  }
  for (const auto& [key, mo] : sweep) {
    util::Timer wall;
    util::CpuTimer cpu;
    fusion::MeshResult m = fusion::MeshPoisson(fused, mo);
    m.mesh.Transform(truth_from_world);
    json e = {{"wall_s", wall.ElapsedSeconds()},
              {"cpu_s", cpu.ElapsedSeconds()},
              {"summary", fusion::ToJson(m.summary)}};
    if (m.summary.ok()) {
      const pipeline::MeshTruthFigures f = pipeline::CompareMeshWithTruth(m.mesh, measured, truth);
      e["rms_mm"] = f.vertices_rms_mm;
      e["truth_rms_mm"] = f.truth_rms_mm;
      // Where the error is: the tail of |vertex - truth| (a few far vertices at the borders
      // or a smooth bias everywhere).
      std::vector<double> d;
      for (double v : f.vertex_deviation_mm) {
        if (std::isfinite(v)) d.push_back(std::abs(v));
      }
      std::sort(d.begin(), d.end());
      // The squared deviation by the vertex's distance to the nearest fused point (in median
      // point spacings): the share of the mean square from vertices Poisson put beyond the
      // data (borders, bridged gaps) against those on it.
      const double spacing = m.summary.spacing_mm;
      const std::vector<double> edges = {0.5, 1, 2, 4};
      std::vector<double> count(edges.size() + 1, 0), sum_sq(edges.size() + 1, 0);
      for (size_t v = 0; v < m.mesh.vertices.size(); ++v) {
        const double dev = f.vertex_deviation_mm[v];
        if (!std::isfinite(dev)) continue;
        const double nn = std::sqrt(support.Nearest(m.mesh.vertices[v]).second) / spacing;
        const size_t b = std::upper_bound(edges.begin(), edges.end(), nn) - edges.begin();
        count[b] += 1;
        sum_sq[b] += dev * dev;
      }
      json by_support = json::array();
      for (size_t b = 0; b < count.size(); ++b) {
        by_support.push_back({{"below_spacings", b < edges.size() ? edges[b] : INFINITY},
                              {"vertices", count[b]},
                              {"rms_mm", count[b] > 0 ? std::sqrt(sum_sq[b] / count[b]) : 0.0},
                              {"share_of_mean_square", sum_sq[b] / std::max(1e-300, [&] {
                                                         double t = 0;
                                                         for (double x : sum_sq) t += x;
                                                         return t;
                                                       }())}});
      }
      e["by_support"] = std::move(by_support);
      for (const double q : {0.5, 0.9, 0.99, 0.999}) {
        e[util::StrCat("abs_p", q * 100)] =
            d.empty() ? 0.0 : d[static_cast<size_t>(q * static_cast<double>(d.size() - 1))];
      }
    }
    util::LogInfo(key + ": " + e.dump());
    (*j)[key] = std::move(e);
  }
}

}  // namespace

int main(int argc, char** argv) {
  fringe::util::UseTransparentHugePages(argv);  // as the fringe program does
  CLI::App app{"bench_pipeline: the whole scanner on the simulated demo scan"};
  bool as_json = false, keep = false;
  int views = 8;
  double rig_scale = 1.0;
  fringe::pipeline::ScanOptions options;
  std::string work = "bench_pipeline_work", reuse_scan;
  app.add_flag("--json", as_json, "Print one JSON object");
  app.add_option("--views", views, "Views around the part")->check(CLI::Range(2, 64));
  app.add_option("--rig-scale", rig_scale, "Camera/projector resolution scale (1: 1280x1024)")
      ->check(CLI::Range(0.1, 1.0));
  app.add_option("--poisson-depth", options.mesh.poisson_depth,
                 "Poisson octree depth (0: from the point spacing and --mesh-resolution)")
      ->capture_default_str();
  app.add_option("--mesh-resolution", options.mesh.resolution_mm,
                 "Wanted mesh resolution, mm (0: as fine as the points allow)")
      ->capture_default_str();
  app.add_option("--work", work, "Work folder (scan and result are written below it)");
  app.add_flag("--keep", keep, "Keep the work folder");
  app.add_option("--scan", reuse_scan,
                 "Scan folder of an earlier run (WORK/scan with --keep) used instead of "
                 "simulating; its rig scale and views are those it was simulated with")
      ->check(CLI::ExistingDirectory);
  app.add_flag(
      "--no-projector-columns", [&](int64_t) { options.fit_projector_columns = false; },
      "Do not fit the projector's columns to the scan when the rig has no projector");
  std::string rig_file;
  app.add_option("--rig", rig_file, "Rig JSON used instead of calibrating from the board images")
      ->check(CLI::ExistingFile);
  std::vector<int> mesh_depths;
  app.add_option("--mesh-depths", mesh_depths,
                 "Mesh the scan's fused cloud again at these Poisson depths and compare each "
                 "with the truth both ways")
      ->delimiter(',')
      ->check(CLI::Range(5, 14));
  app.add_option("--poisson-pieces", options.mesh.poisson_pieces,
                 "Poisson in two pieces: 0 automatic, 1 never, 2 always (fusion::MeshOptions)")
      ->check(CLI::Range(0, 2));
  app.add_flag(
      "--no-mesh-projection", [&](int64_t) { options.mesh.project_to_points = false; },
      "Leave Poisson's vertices where it put them (fusion::MeshOptions::project_to_points)");
  app.add_option("--max-surface-cells", options.mesh.max_surface_cells,
                 "Coarsest automatic Poisson cell: at most this many cells on the surface "
                 "(0: no cap; fusion::MeshOptions)")
      ->capture_default_str();
  app.add_option("--trim-distance", options.mesh.trim_distance_factor,
                 "Mesh vertices farther than this many point spacings from every point are "
                 "trimmed (fusion::MeshOptions::trim_distance_factor)")
      ->capture_default_str();
  std::vector<double> mesh_resolutions;
  app.add_option("--mesh-resolutions", mesh_resolutions,
                 "Mesh the scan's fused cloud again at these wanted resolutions (mm, automatic "
                 "depth) and compare each with the truth both ways")
      ->delimiter(',')
      ->check(CLI::PositiveNumber);
  std::string result_dir;
  app.add_option("--result", result_dir,
                 "Result folder of an earlier run with truth (WORK/out with --keep; give its "
                 "--scan too): only --mesh-depths is run on it, no scan")
      ->check(CLI::ExistingDirectory);
  CLI11_PARSE(app, argc, argv);
  options.calib = rig_file;
  using namespace fringe;
  try {
    if (!as_json) util::SetVerbosity(util::Verbosity::kNormal);
    const fs::path dir = work;
    fs::create_directories(dir);
    if (!result_dir.empty()) {
      if (reuse_scan.empty() || (mesh_depths.empty() && mesh_resolutions.empty())) {
        throw Error(
            "--result needs --scan (the scan folder with the truth) and --mesh-depths or "
            "--mesh-resolutions");
      }
      const json summary = io::ReadJson(fs::path(result_dir) / "summary.json");
      Eigen::Matrix<double, 3, 4> g;
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 4; ++c) g(r, c) = summary.at("truth_from_world").at(r).at(c);
      }
      json j = json::object();
      MeshSweep(result_dir, reuse_scan, Rigid3d::FromMatrix(g), options.mesh, mesh_depths,
                mesh_resolutions, &j);
      std::cout << (as_json ? j.dump() : j.dump(2)) << "\n";
      return 0;
    }
    const StereoRig rig = sim::ScaledRig(StereoRig::Reference(), rig_scale);
    sim::ScanOptions so;
    so.scene = "demo";
    so.views = views;
    // The demo's patterns: heterodyne-4x3 pre-compensated for the simulated projector's gamma.
    so.scheme = phase::MakeScheme("heterodyne-4x3", rig.projector->width, rig.projector->height);
    so.scheme->gamma_precompensation = so.render.projector.gamma;
    so.calibration_images = 15;
    so.truth_maps = false;  // the scan compares with the truth mesh and poses
    util::Timer timer;
    fs::path scan_dir = dir / "scan";
    json simulate_s = nullptr;
    if (reuse_scan.empty()) {
      sim::SimulateScan(rig, so, scan_dir);
      simulate_s = timer.ElapsedSeconds();
    } else {
      scan_dir = reuse_scan;
    }

    const pipeline::ScanSummary s = pipeline::RunScan(scan_dir, dir / "out", options);
    json j = FiguresJson(s);
    const fringe::StereoRig used = io::ReadRig(dir / "out" / "rig.json");
    j["image_width"] = used.left.width;
    j["image_height"] = used.left.height;
    j["simulate_s"] = simulate_s;
    j["peak_mem_gib"] = util::PeakMemoryGiB();  // the whole process, simulation included
    j["calibration_rms_left_px"] = s.calibration_rms_left_px;
    if (!mesh_depths.empty() || !mesh_resolutions.empty()) {
      if (!s.has_truth)
        throw Error("--mesh-depths/--mesh-resolutions need a scan folder with truth");
      MeshSweep(dir / "out", scan_dir, s.truth_from_world, options.mesh, mesh_depths,
                mesh_resolutions, &j);
    }
    if (as_json) {
      std::cout << j.dump() << "\n";
    } else {
      std::cout << s.BriefReport() << "\n";
      for (auto it = j.begin(); it != j.end(); ++it) {
        std::printf("%-24s %s\n", it.key().c_str(), it.value().dump().c_str());
      }
    }
    if (!keep) {
      // Only what this run wrote: a reused scan folder may lie in the work folder.
      fs::remove_all(dir / "out");
      if (reuse_scan.empty()) fs::remove_all(dir / "scan");
      std::error_code ec;
      fs::remove(dir, ec);  // when empty
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_pipeline: %s\n", e.what());
    return 1;
  }
  return 0;
}
