// bench_fusion: accuracy, layer thickness, detail and speed of multi-view fusion (issue 12).
//
// Simulated multi-view scan of the demo part (sim::ScanSimulator, >= 8 views, read noise sigma
// DN), every view reconstructed from its fringe images with the true rig (ViewReconstructor),
// its markers detected in its textures (DetectViewMarkers), and the views registered by the
// registration module (RegisterViews: markers, global adjustment, multi-view ICP; the truth's
// free gauge fixed by the registration's world view), the fusion's registration term set to
// the ICP's final RMS as `fringe scan` does. --registration injected places the views by their
// TRUE poses perturbed by a seeded registration-like error instead (--rot-err-deg,
// --trans-err-mm; registration term max(0.01, trans error)). pose_rot_err_deg and
// pose_centroid_err_mm: the poses' largest errors. The same views are then fused by
//   ours      fusion::FuseViews (adaptive-neighbourhood mean clustering);
//   concat    plain concatenation;
//   voxel     Open3D VoxelDownSample of the concatenation, the voxel tuned (bisection) to give
//             the same point count as ours;
//   tsdf      Open3D ScalableTSDFVolume (voxel = median spacing, truncation 4 voxels) fed with
//             per-view pinhole depth maps, its extracted point cloud;
//   poisson   Open3D screened Poisson on the concatenation (mesh vertices),
// all in this process on the same input. Figures (distances to the truth mesh, mm):
//   fused_rms_mm / *_rms_mm   RMS signed distance of all output points;
//   fused_overlap_rms_mm      ours, the clusters (points fused from >= 2 views);
//   single_view_rms_mm        the single-view points in the same overlap regions;
//   thickness_ratio           spread (std) of the distances of fused overlap points / that of the
//                             single-view overlap points (a double layer would exceed 1);
//   detail_err_mm (+ voxel_, tsdf_, concat_)  RMS distance of output points near fine detail:
//                             places where the part's height field changes by > 0.2 mm within
//                             0.75 mm (the 0.6 mm ribs, the 0.3 mm engraving, step edges);
//   mesh_rms_mm               our mesh's vertices to the truth; mesh_truth_rms_mm truth points
//                             (the truth surface where measured) to our mesh; mesh_watertight;
//                             mesh_watertight_option (the --watertight mesh); mesh_cgal_* the
//                             same figures of CGAL's Poisson on the same fused cloud;
//   points, time_s (fusion), mesh_time_s, peak_mem_gib (peak RSS growth during fusion).
//
// Usage: bench_fusion [--json] [--views 8] [--scale 0.5] [--noise 1.5]
//                     [--registration module|injected] [--rot-err-deg 0.005]
//                     [--trans-err-mm 0.01] [--poisson-depth 10] [--no-peers] [--no-mesh]
//                     [--no-cgal] [--cgal-budget-gib 0] [--cgal-budget-s 300] [--cache DIR]
//                     [--diagnose]
// CGAL's Poisson (the meshing peer) runs within a memory and time budget (default: half the
// available memory, at most 8 GiB, and 300 s); past either it is stopped and skipped, with the
// reason in mesh_cgal_skipped (it grew past 23 GB on the demo part).
#include <sys/resource.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <open3d/camera/PinholeCameraIntrinsic.h>
#include <open3d/geometry/Image.h>
#include <open3d/geometry/KDTreeFlann.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/geometry/RGBDImage.h>
#include <open3d/geometry/TriangleMesh.h>
#include <open3d/pipelines/integration/ScalableTSDFVolume.h>
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <new>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "fringe/eval/deviation.h"
#include "fringe/fusion/fuse.h"
#include "fringe/fusion/mesh.h"
#include "fringe/io/json.h"
#include "fringe/io/ply.h"
#include "fringe/registration/markers.h"
#include "fringe/registration/register_views.h"
#include "fringe/sim/demo_part.h"
#include "fringe/sim/scan.h"
#include "fringe/stereo/reconstruct_view.h"
#include "fringe/util/error.h"
#include "fringe/util/memory.h"
#include "fringe/util/random.h"
#include "fringe/util/timer.h"

namespace fringe {
namespace {

constexpr double kMaxDistanceMm = 2.0;  // farther points are unmatched (not the part)

// Restarts the peak resident size (VmHWM) so that the fusion's own peak is measured (Linux >= 4.0).
void ResetPeak() { std::ofstream("/proc/self/clear_refs") << "5"; }

// Process CPU time (user + system, all threads), s: on a shared machine wall time depends on
// the load, CPU time far less.
double LoadAverage() {
  double load = 0;
  std::ifstream("/proc/loadavg") >> load;
  return load;
}

double CpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

// Memory the kernel can still give this process (MemAvailable), GiB; 0 when unknown.
double AvailableMemoryGiB() {
  std::ifstream in("/proc/meminfo");
  std::string key;
  double kib = 0;
  std::string unit;
  while (in >> key >> kib >> unit) {
    if (key == "MemAvailable:") return kib / (1024.0 * 1024.0);
  }
  return 0;
}

// Address space of this process (VmSize), bytes.
double AddressSpaceBytes() {
  std::ifstream in("/proc/self/statm");
  double pages = 0;
  in >> pages;
  return pages * static_cast<double>(sysconf(_SC_PAGESIZE));
}

// Runs f with at most budget_gib more address space and budget_s seconds: past either, the
// next allocation fails (RLIMIT_AS lowered, at the deadline by a watchdog thread) and f's
// std::bad_alloc is caught. Returns "" when f finished, else why it was stopped. For a peer
// whose memory cannot be predicted (CGAL's Poisson grew past 23 GB on the demo part): it must
// not exhaust the machine, and the run must end in a known time.
template <typename F>
std::string RunWithinBudget(double budget_gib, double budget_s, F&& f) {
  rlimit old{};
  getrlimit(RLIMIT_AS, &old);
  auto set_limit = [&](double bytes) {
    rlimit lim = old;
    lim.rlim_cur = static_cast<rlim_t>(bytes);
    if (old.rlim_max != RLIM_INFINITY) lim.rlim_cur = std::min(lim.rlim_cur, old.rlim_max);
    setrlimit(RLIMIT_AS, &lim);
  };
  set_limit(AddressSpaceBytes() + budget_gib * 1024.0 * 1024.0 * 1024.0);
  std::mutex m;
  std::condition_variable cv;
  bool done = false, timed_out = false;
  std::thread watchdog([&] {
    std::unique_lock<std::mutex> lock(m);
    if (!cv.wait_for(lock, std::chrono::duration<double>(budget_s), [&] { return done; })) {
      timed_out = true;
      set_limit(AddressSpaceBytes());  // no more memory: f's next allocation throws
    }
  });
  std::string why;
  try {
    f();
  } catch (const std::bad_alloc&) {
    why = "stopped";
  }
  {
    std::lock_guard<std::mutex> lock(m);
    done = true;
  }
  cv.notify_one();
  watchdog.join();
  setrlimit(RLIMIT_AS, &old);
  if (why.empty()) return why;
  return timed_out ? util::StrCat("skipped: did not finish within ", budget_s, " s")
                   : util::StrCat("skipped: needed more than ", budget_gib,
                                  " GiB beyond the process's memory");
}

std::string DigestHex(uint64_t digest) {
  char text[17];
  std::snprintf(text, sizeof(text), "%016llx", static_cast<unsigned long long>(digest));
  return text;
}

struct Stats {
  int n = 0, unmatched = 0;
  double rms = 0, p95 = 0, mean = 0, spread = 0;
};

Stats StatsOf(const std::vector<double>& d_all) {
  Stats s;
  std::vector<double> a;
  double sum = 0, sum_sq = 0;
  for (double d : d_all) {
    if (!std::isfinite(d)) {
      ++s.unmatched;
      continue;
    }
    sum += d, sum_sq += d * d;
    a.push_back(std::abs(d));
  }
  s.n = static_cast<int>(a.size());
  if (s.n == 0) return s;
  s.mean = sum / s.n;
  s.rms = std::sqrt(sum_sq / s.n);
  s.spread = std::sqrt(std::max(0.0, sum_sq / s.n - s.mean * s.mean));
  std::nth_element(a.begin(), a.begin() + a.size() * 95 / 100, a.end());
  s.p95 = a[a.size() * 95 / 100];
  return s;
}

std::vector<double> Distances(const std::vector<Eigen::Vector3d>& pts, const MeshIndex& m) {
  std::vector<double> d(pts.size());
  tbb::parallel_for(size_t{0}, pts.size(),
                    [&](size_t i) { d[i] = m.SignedDistance(pts[i], kMaxDistanceMm); });
  return d;
}

// Near fine detail: the part's height field changes by more than 0.2 mm within 0.75 mm, and the
// point lies on the part's top surface (not a wall or the plate).
bool NearDetail(const Eigen::Vector3d& p) {
  const double h = sim::DemoPartHeight(p.x(), p.y());
  if (h <= 0 || std::abs(p.z() - h) > 1.0) return false;
  constexpr double kStepMm = 0.75, kJumpMm = 0.2;
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      if (std::abs(sim::DemoPartHeight(p.x() + dx * kStepMm, p.y() + dy * kStepMm) - h) > kJumpMm) {
        return true;
      }
    }
  }
  return false;
}

double DetailRms(const std::vector<Eigen::Vector3d>& pts, const std::vector<double>& d) {
  std::vector<double> sel;
  for (size_t i = 0; i < pts.size(); ++i) {
    if (NearDetail(pts[i])) sel.push_back(d[i]);
  }
  return StatsOf(sel).rms;
}

open3d::geometry::PointCloud ToOpen3d(const std::vector<fusion::FusionView>& views) {
  open3d::geometry::PointCloud pcd;
  for (const auto& v : views) {
    for (size_t i = 0; i < v.cloud.valid.size(); ++i) {
      if (!v.cloud.valid[i]) continue;
      pcd.points_.push_back(v.world_from_sensor * v.cloud.cloud.points[i]);
      const Eigen::Vector3d n = v.world_from_sensor.RotateDirection(v.cloud.cloud.normals[i]);
      pcd.normals_.push_back(n.allFinite() ? n : Eigen::Vector3d(0, 0, 1));
    }
  }
  return pcd;
}

// Where the errors are: every view point's distance to the truth binned by its grid distance to
// the view's border (nearest invalid slot), its viewing-angle cosine, modulation and residual,
// separately for points in overlaps and outside them (the latter pass through fusion). Prints
// count, RMS and share of the total squared error per bin to stderr.
void Diagnose(const std::vector<fusion::FusionView>& views, const fusion::FusionResult& fused,
              const MeshIndex& truth) {
  struct Bin {
    int64_t n = 0;
    double sq = 0;
  };
  constexpr int kKinds = 5, kBins = 8;
  const char* kind_name[kKinds] = {"border px", "cos view", "modulation DN", "residual px",
                                   "cos, border<2"};
  const double edges[kKinds][kBins - 1] = {{1, 2, 3, 4, 6, 10, 20},
                                           {0.1, 0.2, 0.3, 0.4, 0.5, 0.7, 0.9},
                                           {5, 10, 15, 20, 30, 40, 60},
                                           {0.05, 0.1, 0.2, 0.3, 0.5, 1, 2},
                                           {0.1, 0.2, 0.3, 0.4, 0.5, 0.7, 0.9}};
  Bin bins[2][kKinds][kBins];
  double total_sq[2] = {0, 0};
  int64_t total_n[2] = {0, 0}, far_n[2] = {0, 0};
  for (size_t v = 0; v < views.size(); ++v) {
    const OrganizedPointCloud& g = views[v].cloud;
    const std::vector<uint16_t> border =
        fusion::BorderDistancePx(g, fusion::FusionOptions().min_border_hole_px);
    std::vector<double> d(g.valid.size(), std::numeric_limits<double>::quiet_NaN());
    tbb::parallel_for(size_t{0}, g.valid.size(), [&](size_t i) {
      if (g.valid[i])
        d[i] = truth.SignedDistance(views[v].world_from_sensor * g.cloud.points[i], kMaxDistanceMm);
    });
    const PointCloud& c = g.cloud;
    for (size_t i = 0; i < g.valid.size(); ++i) {
      if (!g.valid[i]) continue;
      const int o = fused.overlap[v][i] ? 1 : 0;
      if (!std::isfinite(d[i])) {
        ++far_n[o];
        continue;
      }
      const double sq = d[i] * d[i];
      total_sq[o] += sq;
      ++total_n[o];
      const Eigen::Vector3d& p = c.points[i];
      double x[kKinds] = {
          static_cast<double>(border[i]),
          c.normals[i].allFinite() ? std::abs(c.normals[i].dot(p)) / p.norm() : -1.0,
          c.has_quality() ? c.quality[i] : -1.0, c.has_residual() ? c.residual_px[i] : -1.0, 0.0};
      x[4] = x[1];
      for (int k = 0; k < kKinds; ++k) {
        if (k == 4 && border[i] >= 2) continue;
        const int b =
            static_cast<int>(std::upper_bound(edges[k], edges[k] + kBins - 1, x[k]) - edges[k]);
        bins[o][k][b].n++;
        bins[o][k][b].sq += sq;
      }
    }
  }
  for (int o = 1; o >= 0; --o) {
    std::fprintf(stderr, "%s points: %lld, RMS %.4f mm, %lld beyond %.1f mm (unmatched)\n",
                 o ? "overlap" : "non-overlap", static_cast<long long>(total_n[o]),
                 std::sqrt(total_sq[o] / std::max<int64_t>(total_n[o], 1)),
                 static_cast<long long>(far_n[o]), kMaxDistanceMm);
    for (int k = 0; k < kKinds; ++k) {
      std::fprintf(stderr, "  %-14s", kind_name[k]);
      for (int b = 0; b < kBins; ++b) {
        const Bin& x = bins[o][k][b];
        std::fprintf(stderr, " | <%-5g n %5.1f%% rms %.3f sq %4.1f%%",
                     b < kBins - 1 ? edges[k][b] : INFINITY,
                     100.0 * x.n / std::max<int64_t>(total_n[o], 1),
                     std::sqrt(x.sq / std::max<int64_t>(x.n, 1)),
                     100.0 * x.sq / std::max(total_sq[o], 1e-30));
      }
      std::fprintf(stderr, "\n");
    }
  }
}

}  // namespace
}  // namespace fringe

int main(int argc, char** argv) {
  fringe::util::UseTransparentHugePages(argv);  // as the fringe program does
  using namespace fringe;
  CLI::App app("bench_fusion: multi-view fusion of the simulated demo part vs alternatives");
  bool json = false, peers = true, mesh = true;
  int views_n = 8, poisson_depth = 0;
  double scale = 0.5, noise_dn = 1.5, rot_err_deg = 0.005, trans_err_mm = 0.01;
  uint64_t seed = 1;
  app.add_flag("--json", json, "Print one JSON object");
  app.add_option("--views", views_n, "Views around the part (>= 2)")->capture_default_str();
  app.add_option("--scale", scale, "Rig resolution scale (1: 1280x1024 cameras)")
      ->capture_default_str();
  app.add_option("--noise", noise_dn, "Camera read noise, DN")->capture_default_str();
  std::string registration_mode = "module";
  app.add_option("--registration", registration_mode,
                 "How the views are placed: 'module' (RegisterViews on the views' clouds and the "
                 "markers detected in their textures) or 'injected' (true poses perturbed by "
                 "--rot-err-deg and --trans-err-mm)")
      ->check(CLI::IsMember({"module", "injected"}))
      ->capture_default_str();
  app.add_option("--rot-err-deg", rot_err_deg, "Injected registration rotation error per view")
      ->capture_default_str();
  app.add_option("--trans-err-mm", trans_err_mm, "Injected registration translation error")
      ->capture_default_str();
  app.add_option("--poisson-depth", poisson_depth,
                 "Poisson octree depth (0: from the point spacing)")
      ->capture_default_str();
  app.add_option("--seed", seed, "Scene, noise and error seed")->capture_default_str();
  std::string cache;
  app.add_option("--cache", cache,
                 "Folder keeping the reconstructed views (PLY + poses): reused when it holds "
                 "views of the same parameters, else written (saves the simulation when "
                 "re-running the fusion)");
  bool no_peers = false, no_mesh = false, diagnose = false;
  app.add_flag("--diagnose", diagnose,
               "Print where the views' errors are (border, viewing angle, modulation, residual)");
  app.add_flag("--no-peers", no_peers, "Skip voxel, TSDF and Poisson-on-concatenation");
  app.add_flag("--no-mesh", no_mesh, "Skip meshing");
  fusion::FusionOptions options;
  app.add_option("--lateral-sigma", options.lateral_sigma,
                 "Fusion: member weight width beside the centre's normal line, spacings")
      ->capture_default_str();
  app.add_option("--spacing-factor", options.spacing_factor,
                 "Fusion: neighbourhood radius, spacings")
      ->capture_default_str();
  app.add_option("--smooth-radius", options.smooth_radius_px,
                 "Fusion: single-coverage smoothing window radius, px (0: off)")
      ->capture_default_str();
  app.add_option("--one-view-cluster-border", options.one_view_cluster_border_px,
                 "Fusion: one-view clusters whose seed is this close to a border are dropped, px")
      ->capture_default_str();
  app.add_option("--seed-factor", options.seed_factor,
                 "Fusion: seed radius, spacings (sparser seeds: larger clusters)")
      ->capture_default_str();
  app.add_option("--border-seed-factor", options.border_seed_factor,
                 "Fusion: seed radius near a view's border, spacings")
      ->capture_default_str();
  app.add_option("--border-seed", options.border_seed_px,
                 "Fusion: border distance below which the border seed radius applies, px")
      ->capture_default_str();
  app.add_option("--border-trim", options.border_trim_px,
                 "Fusion: single-coverage points this close to a border are trimmed, px")
      ->capture_default_str();
  bool no_cgal = false;
  app.add_flag("--no-cgal", no_cgal, "Skip CGAL's Poisson (the meshing peer)");
  double cgal_budget_gib = 0, cgal_budget_s = 300;
  app.add_option("--cgal-budget-gib", cgal_budget_gib,
                 "Memory CGAL's Poisson may take beyond the process's; past it the peer is "
                 "skipped with a note (0: half the available memory, at most 8 GiB)");
  app.add_option("--cgal-budget-s", cgal_budget_s,
                 "Time CGAL's Poisson may take; past it the peer is skipped with a note")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  peers = !no_peers;
  const bool injected = registration_mode == "injected";
  mesh = !no_mesh;
  const bool cgal = !no_cgal;

  // Simulate and reconstruct the views.
  const StereoRig rig =
      scale == 1 ? StereoRig::Reference() : sim::ScaledRig(StereoRig::Reference(), scale);
  sim::ScanOptions scan;
  scan.scene = "demo";
  scan.views = views_n;
  scan.seed = seed;
  scan.calibration_images = 0;
  scan.truth_maps = false;
  scan.render.sensor.read_noise_dn = noise_dn;
  const sim::ScanSimulator simulator(rig, scan);
  const stereo::ViewReconstructor reconstructor(rig, simulator.scheme());
  std::vector<fusion::FusionView> views;
  std::vector<std::vector<registration::ViewMarker>> markers(views_n);
  util::Timer sim_timer;
  double reconstruct_s = 0;
  // The cache keeps what the simulation and reconstruction give: the views' clouds and the
  // markers detected in their textures (not the poses: they come from the registration or the
  // injected error below).
  const nlohmann::json params = {
      {"views", views_n}, {"scale", scale}, {"noise", noise_dn}, {"seed", seed}, {"format", 2}};
  const std::filesystem::path cache_dir(cache);
  // Cached views are read back as written (float PLY), so that every run fuses the same input.
  auto load_cache = [&] {
    const nlohmann::json cached = io::ReadJson(cache_dir / "views.json");
    if (cached["params"] != params) return;
    views.clear();
    for (int v = 0; v < views_n; ++v) {
      const std::string stem = (cache_dir / std::to_string(v)).string();
      views.push_back({std::to_string(v), io::ReadOrganizedPly(stem + ".ply"), Rigid3d()});
      markers[v] = registration::ReadViewMarkers(stem + ".markers.json");
    }
  };
  if (!cache.empty() && std::filesystem::exists(cache_dir / "views.json")) load_cache();
  for (int v = static_cast<int>(views.size()); v < views_n; ++v) {
    const sim::ViewImages images = simulator.RenderView(v);
    util::Timer t;
    stereo::ViewReconstruction rec =
        reconstructor.Reconstruct(images.left.images, images.right.images);
    reconstruct_s += t.ElapsedSeconds();
    markers[v] =
        registration::DetectViewMarkers(rig, rec.texture_left, rec.texture_right, rec.cloud)
            .markers;
    views.push_back({std::to_string(v), std::move(rec.cloud), Rigid3d()});
  }
  const double sim_s = sim_timer.ElapsedSeconds();
  if (!cache.empty() && !std::filesystem::exists(cache_dir / "views.json")) {
    std::filesystem::create_directories(cache_dir);
    for (int v = 0; v < views_n; ++v) {
      const std::string stem = (cache_dir / std::to_string(v)).string();
      io::WritePly(stem + ".ply", views[v].cloud);
      registration::WriteViewMarkers(stem + ".markers.json", markers[v]);
    }
    io::WriteJson(cache_dir / "views.json", {{"params", params}});  // last: the cache is whole
    load_cache();
  }

  // Poses.
  const std::vector<Rigid3d>& truth_poses = simulator.view_poses();
  double register_s = 0, registration_rms_mm = 0;
  std::string registration_report;
  if (injected) {
    // A registration-like error: random axis, rotation about the view's origin, translation.
    std::mt19937_64 rng(util::MixSeed(seed, 12));
    std::normal_distribution<double> gauss(0, 1);
    for (int v = 0; v < views_n; ++v) {
      const Eigen::Vector3d axis = Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)).normalized();
      const Eigen::Vector3d dir = Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)).normalized();
      const Rigid3d error =
          v == 0 ? Rigid3d()
                 : Rigid3d::FromAxisAngle(axis, rot_err_deg * M_PI / 180, trans_err_mm * dir);
      views[v].world_from_sensor = error * truth_poses[v];
    }
    registration_rms_mm = std::max(0.01, trans_err_mm);
    registration_report = "true poses + injected error";
  } else {
    // The registration module on the views' clouds and detected markers, as `fringe register`.
    std::vector<registration::RegistrationView> rv(views_n);
    for (int v = 0; v < views_n; ++v) {
      rv[v].name = views[v].name;
      rv[v].cloud = views[v].cloud.Compact();
      rv[v].markers = markers[v];
    }
    util::Timer t;
    const registration::RegistrationResult r = registration::RegisterViews(rv);
    register_s = t.ElapsedSeconds();
    registration_report = r.summary.BriefReport();
    int world = -1;
    for (int v = 0; v < views_n; ++v) {
      if (!r.views[v].placed()) {
        std::cerr << "bench_fusion: view " << v << " not registered: " << r.views[v].message
                  << "\n";
        return 1;
      }
      if (r.views[v].path == registration::ViewPath::kWorld) world = v;
    }
    if (world < 0) throw Error("bench_fusion: the registration names no world view");
    // The registration's world is its world view's sensor frame; the truth's gauge is free, so
    // it is fixed by that view's true pose (as the injected mode leaves view 0 exact).
    const Rigid3d truth_from_registered =
        truth_poses[world] * r.views[world].world_from_sensor.Inverse();
    for (int v = 0; v < views_n; ++v) {
      views[v].world_from_sensor = truth_from_registered * r.views[v].world_from_sensor;
    }
    // The fusion's registration term, as `fringe scan` sets it: the ICP's final RMS.
    registration_rms_mm =
        r.summary.icp.levels.empty() ? 0.01 : std::max(0.0, r.summary.icp.levels.back().rms_end_mm);
  }
  // The poses' errors: rotation and the displacement of the view's cloud centroid, max.
  double pose_rot_err_deg = 0, pose_centroid_err_mm = 0;
  for (int v = 0; v < views_n; ++v) {
    const Rigid3d e = views[v].world_from_sensor * truth_poses[v].Inverse();
    const Eigen::AngleAxisd aa(e.rotation_matrix());
    pose_rot_err_deg = std::max(pose_rot_err_deg, std::abs(aa.angle()) * 180 / M_PI);
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    int64_t n = 0;
    const OrganizedPointCloud& g = views[v].cloud;
    for (size_t i = 0; i < g.valid.size(); ++i) {
      if (g.valid[i]) c += g.cloud.points[i], ++n;
    }
    if (n > 0) c /= static_cast<double>(n);
    const Eigen::Vector3d c_true = truth_poses[v] * c;
    pose_centroid_err_mm = std::max(pose_centroid_err_mm, (e * c_true - c_true).norm());
  }
  int64_t input_points = 0;
  for (const auto& v : views) input_points += static_cast<int64_t>(v.cloud.NumValid());

  const MeshIndex truth(simulator.scene().CombinedMesh());

  // Ours.
  options.registration_rms_mm = registration_rms_mm;
  const double mem_before = util::CurrentMemoryGiB();
  ResetPeak();
  util::Timer fuse_timer;
  const double cpu_before = CpuSeconds();
  const fusion::FusionResult fused = fusion::FuseViews(views, options);
  const double time_s = fuse_timer.ElapsedSeconds();
  const double cpu_s = CpuSeconds() - cpu_before;
  const double peak_mem_gib = util::PeakMemoryGiB() - mem_before;
  if (!fused.summary.has_output()) {
    std::cerr << fused.summary.BriefReport() << "\n";
    return 1;
  }
  if (diagnose) Diagnose(views, fused, truth);
  const std::vector<double> d_fused = Distances(fused.fused.points, truth);
  std::vector<double> d_fused_overlap, d_fused_lone_cluster, d_fused_passed;
  for (size_t i = 0; i < d_fused.size(); ++i) {
    if (fused.support[i] >= 2) {
      d_fused_overlap.push_back(d_fused[i]);
    } else if (static_cast<int64_t>(i) < fused.summary.clusters) {
      d_fused_lone_cluster.push_back(d_fused[i]);  // a cluster whose members came from one view
    } else {
      d_fused_passed.push_back(d_fused[i]);
    }
  }
  // Single-view points in the overlaps, and the plain concatenation.
  std::vector<Eigen::Vector3d> concat, single_overlap;
  for (size_t v = 0; v < views.size(); ++v) {
    const auto& g = views[v].cloud;
    for (size_t i = 0; i < g.valid.size(); ++i) {
      if (!g.valid[i]) continue;
      const Eigen::Vector3d p = views[v].world_from_sensor * g.cloud.points[i];
      concat.push_back(p);
      if (fused.overlap[v][i]) single_overlap.push_back(p);
    }
  }
  const std::vector<double> d_concat = Distances(concat, truth);
  const std::vector<double> d_single = Distances(single_overlap, truth);
  // Coverage: the truth surface where the views measured it (the closest truth points of every
  // 7th concatenated point) with a fused point within 3 median spacings; points the fusion
  // absorbed must not open holes.
  double coverage = 0;
  {
    open3d::geometry::PointCloud fused_pcd;
    fused_pcd.points_ = fused.fused.points;
    const open3d::geometry::KDTreeFlann tree(fused_pcd);
    const double reach = 3 * fused.summary.median_spacing_mm;
    int64_t covered = 0, sampled = 0;
    for (size_t i = 0; i < concat.size(); i += 7) {
      Eigen::Vector3d q;
      if (!std::isfinite(truth.SignedDistance(concat[i], kMaxDistanceMm, &q))) continue;
      std::vector<int> idx(1);
      std::vector<double> d2(1);
      ++sampled;
      covered += tree.SearchKNN(q, 1, idx, d2) == 1 && d2[0] <= reach * reach;
    }
    coverage = static_cast<double>(covered) / std::max<int64_t>(sampled, 1);
  }
  // A digest of our output (FNV-1a over every fused point's bytes: position, normal, intensity,
  // quality, support): two builds whose digests agree on the same views fused identically.
  uint64_t fused_digest = 14695981039346656037ull;
  auto digest = [&fused_digest](const void* data, size_t bytes) {
    const auto* b = static_cast<const unsigned char*>(data);
    for (size_t k = 0; k < bytes; ++k) fused_digest = (fused_digest ^ b[k]) * 1099511628211ull;
  };
  for (size_t i = 0; i < fused.fused.size(); ++i) {
    digest(fused.fused.points[i].data(), sizeof(double) * 3);
    digest(fused.fused.normals[i].data(), sizeof(double) * 3);
    digest(&fused.fused.intensity[i], sizeof(float));
    digest(&fused.fused.quality[i], sizeof(float));
    digest(&fused.support[i], sizeof(uint16_t));
  }
  const Stats s_fused = StatsOf(d_fused), s_overlap = StatsOf(d_fused_overlap),
              s_single = StatsOf(d_single), s_concat = StatsOf(d_concat);

  nlohmann::json j = {
      {"views", views_n},
      {"scale", scale},
      {"camera", std::to_string(rig.left.width) + "x" + std::to_string(rig.left.height)},
      {"noise_dn", noise_dn},
      {"registration", injected ? "injected" : "module"},
      {"registration_summary", registration_report},
      {"register_s", register_s},
      {"registration_rms_mm", registration_rms_mm},
      {"pose_rot_err_deg", pose_rot_err_deg},
      {"pose_centroid_err_mm", pose_centroid_err_mm},
      {"rot_err_deg", injected ? rot_err_deg : 0.0},
      {"trans_err_mm", injected ? trans_err_mm : 0.0},
      {"input_points", input_points},
      {"points", fused.fused.size()},
      {"fused_digest", DigestHex(fused_digest)},
      {"fused_rms_mm", s_fused.rms},
      {"fused_p95_mm", s_fused.p95},
      {"fused_overlap_rms_mm", s_overlap.rms},
      {"fused_overlap_points", s_overlap.n},
      {"fused_one_view_cluster_rms_mm", StatsOf(d_fused_lone_cluster).rms},
      {"fused_one_view_clusters", d_fused_lone_cluster.size()},
      {"fused_passed_rms_mm", StatsOf(d_fused_passed).rms},
      {"fused_passed_points", d_fused_passed.size()},
      {"single_view_rms_mm", s_single.rms},
      {"single_view_p95_mm", s_single.p95},
      {"overlap_rms_ratio", s_overlap.rms / s_single.rms},
      {"concat_rms_mm", s_concat.rms},
      {"concat_p95_mm", s_concat.p95},
      {"thickness_ratio", s_overlap.spread / s_single.spread},
      {"fused_to_single_ratio", s_fused.rms / s_single.rms},
      {"coverage", coverage},
      {"absorbed", fused.summary.absorbed},
      {"detail_err_mm", DetailRms(fused.fused.points, d_fused)},
      {"concat_detail_err_mm", DetailRms(concat, d_concat)},
      {"time_s", time_s},
      {"cpu_s", cpu_s},
      {"load_average", LoadAverage()},
      {"peak_mem_gib", peak_mem_gib},
      {"simulate_reconstruct_s", sim_s},
      {"reconstruct_s", reconstruct_s},
      {"fusion_summary", fused.summary.BriefReport()},
      {"fusion", fusion::ToJson(fused.summary)}};

  if (peers) {
    const open3d::geometry::PointCloud pcd = ToOpen3d(views);
    // Voxel averaging tuned to our point count.
    double lo = 0.01, hi = 10;
    std::shared_ptr<open3d::geometry::PointCloud> voxel;
    double voxel_mm = 0;
    util::Timer voxel_timer;
    for (int it = 0; it < 30; ++it) {
      voxel_mm = std::sqrt(lo * hi);
      voxel = pcd.VoxelDownSample(voxel_mm);
      if (voxel->points_.size() > fused.fused.size())
        lo = voxel_mm;
      else
        hi = voxel_mm;
      if (std::abs(static_cast<double>(voxel->points_.size()) / fused.fused.size() - 1) < 0.01)
        break;
    }
    const std::vector<double> d_voxel = Distances(voxel->points_, truth);
    j["voxel_mm"] = voxel_mm;
    j["voxel_points"] = voxel->points_.size();
    j["voxel_rms_mm"] = StatsOf(d_voxel).rms;
    j["voxel_p95_mm"] = StatsOf(d_voxel).p95;
    j["voxel_detail_err_mm"] = DetailRms(voxel->points_, d_voxel);
    j["voxel_tuning_s"] = voxel_timer.ElapsedSeconds();

    // TSDF from per-view pinhole depth maps (points splatted to their nearest pixel).
    const double tsdf_voxel = fused.summary.median_spacing_mm;
    open3d::pipelines::integration::ScalableTSDFVolume volume(
        tsdf_voxel, 4 * tsdf_voxel, open3d::pipelines::integration::TSDFVolumeColorType::NoColor);
    const CameraModel& cam = rig.left;
    const open3d::camera::PinholeCameraIntrinsic intrinsic(cam.width, cam.height, cam.fx, cam.fy,
                                                           cam.cx, cam.cy);
    util::Timer tsdf_timer;
    for (const auto& v : views) {
      open3d::geometry::Image depth, color;
      depth.Prepare(cam.width, cam.height, 1, 4);
      color.Prepare(cam.width, cam.height, 3, 1);
      std::fill(depth.data_.begin(), depth.data_.end(), 0);
      std::fill(color.data_.begin(), color.data_.end(), 128);
      for (size_t i = 0; i < v.cloud.valid.size(); ++i) {
        if (!v.cloud.valid[i]) continue;
        const Eigen::Vector3d& p = v.cloud.cloud.points[i];
        const int u = static_cast<int>(std::lround(cam.fx * p.x() / p.z() + cam.cx));
        const int r = static_cast<int>(std::lround(cam.fy * p.y() / p.z() + cam.cy));
        if (u < 0 || r < 0 || u >= cam.width || r >= cam.height) continue;
        float* z = depth.PointerAt<float>(u, r);
        if (*z == 0 || p.z() < *z) *z = static_cast<float>(p.z());
      }
      const auto rgbd =
          open3d::geometry::RGBDImage::CreateFromColorAndDepth(color, depth, 1.0, 1e6, true);
      volume.Integrate(*rgbd, intrinsic, v.world_from_sensor.Inverse().ToMatrix4());
    }
    const auto tsdf = volume.ExtractPointCloud();
    j["tsdf_s"] = tsdf_timer.ElapsedSeconds();
    const std::vector<double> d_tsdf = Distances(tsdf->points_, truth);
    j["tsdf_voxel_mm"] = tsdf_voxel;
    j["tsdf_points"] = tsdf->points_.size();
    j["tsdf_rms_mm"] = StatsOf(d_tsdf).rms;
    j["tsdf_p95_mm"] = StatsOf(d_tsdf).p95;
    j["tsdf_detail_err_mm"] = DetailRms(tsdf->points_, d_tsdf);
    // Same-run ratios to the peer (scripts/bench-check.sh): its time over ours, its RMS over ours.
    j["speedup_vs_tsdf"] = j["tsdf_s"].get<double>() / time_s;
    j["rms_ratio_tsdf_over_fused"] = StatsOf(d_tsdf).rms / s_fused.rms;

    // Poisson on the concatenation.
    if (mesh) {
      PointCloud concat_cloud;
      concat_cloud.points = pcd.points_;
      concat_cloud.normals = pcd.normals_;
      fusion::MeshOptions mo;
      mo.poisson_depth = poisson_depth;
      util::Timer t;
      const fusion::MeshResult m = fusion::MeshPoisson(concat_cloud, mo);
      j["poisson_concat_s"] = t.ElapsedSeconds();
      j["poisson_concat_rms_mm"] = StatsOf(Distances(m.mesh.vertices, truth)).rms;
    }
  }

  if (mesh) {
    // Truth points where measured (closest truth points of the concatenation, every 7th) to
    // a mesh: holes and missing surface show here.
    std::vector<Eigen::Vector3d> truth_pts;
    for (size_t i = 0; i < concat.size(); i += 7) {
      Eigen::Vector3d q;
      if (std::isfinite(truth.SignedDistance(concat[i], kMaxDistanceMm, &q)))
        truth_pts.push_back(q);
    }
    // The same fused cloud meshed by Open3D (ours) and, unless --no-cgal, by CGAL: distance
    // to the truth both ways, time, peak memory growth, triangles.
    auto run_mesh = [&](const fusion::MeshOptions& mo, const std::string& prefix) {
      const double before = util::CurrentMemoryGiB();
      ResetPeak();
      util::Timer t;
      const double cpu0 = CpuSeconds();
      fusion::MeshResult m = fusion::MeshPoisson(fused.fused, mo);
      j[prefix + "time_s"] = t.ElapsedSeconds();
      j[prefix + "cpu_s"] = CpuSeconds() - cpu0;
      j[prefix + "peak_mem_gib"] = util::PeakMemoryGiB() - before;
      j[prefix + "summary"] = m.summary.BriefReport();
      if (m.summary.ok()) {
        j[prefix + "rms_mm"] = StatsOf(Distances(m.mesh.vertices, truth)).rms;
        j[prefix + "watertight"] = m.summary.watertight;
        j[prefix + "triangles"] = m.summary.triangles;
        const MeshIndex surface(m.mesh);
        j[prefix + "truth_rms_mm"] = StatsOf(Distances(truth_pts, surface)).rms;
      }
      return m;
    };
    fusion::MeshOptions mo;
    mo.poisson_depth = poisson_depth;
    const fusion::MeshResult m = run_mesh(mo, "mesh_");
    if (cgal) {
      fusion::MeshOptions co = mo;
      co.library = fusion::MeshLibrary::kCgal;
      const double budget_gib =
          cgal_budget_gib > 0 ? cgal_budget_gib : std::min(8.0, 0.5 * AvailableMemoryGiB());
      j["mesh_cgal_budget_gib"] = budget_gib;
      j["mesh_cgal_budget_s"] = cgal_budget_s;
      util::Timer t;
      const std::string note =
          RunWithinBudget(budget_gib, cgal_budget_s, [&] { run_mesh(co, "mesh_cgal_"); });
      if (!note.empty()) {
        j["mesh_cgal_skipped"] = note;
        j["mesh_cgal_time_s"] = t.ElapsedSeconds();
      }
    }
    if (m.summary.ok()) {
      fusion::MeshOptions wt = mo;
      wt.watertight = true;
      const fusion::MeshResult closed = fusion::MeshPoisson(fused.fused, wt);
      j["mesh_watertight_option"] = closed.summary.watertight;
      j["mesh_watertight_summary"] = closed.summary.BriefReport();
    }
  }

  if (json) {
    std::cout << j.dump() << "\n";
  } else {
    std::printf(
        "bench_fusion: %d views of %s cameras, noise %.1f DN, registration error %.4f deg "
        "/ %.3f mm\n",
        views_n, j["camera"].get<std::string>().c_str(), noise_dn, rot_err_deg, trans_err_mm);
    std::printf("%-28s %12s %12s %12s\n", "method", "points", "RMS mm", "detail mm");
    auto row = [&](const char* name, const char* pts, const char* rms, const char* det) {
      auto num = [&](const char* k) { return j.contains(k) ? j[k].dump() : std::string("-"); };
      std::printf("%-28s %12s %12s %12s\n", name, num(pts).c_str(), num(rms).c_str(),
                  num(det).c_str());
    };
    row("ours (fused)", "points", "fused_rms_mm", "detail_err_mm");
    row("concatenation", "input_points", "concat_rms_mm", "concat_detail_err_mm");
    row("voxel averaging", "voxel_points", "voxel_rms_mm", "voxel_detail_err_mm");
    row("Open3D TSDF", "tsdf_points", "tsdf_rms_mm", "tsdf_detail_err_mm");
    std::cout << j.dump(2) << "\n";
  }
  return 0;
}
