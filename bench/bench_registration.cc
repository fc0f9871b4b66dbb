// bench_registration: accuracy and speed of multi-view registration (issue 11).
//
// Simulated multi-view scan of the demo part (sim::ScanSimulator, --views around it, read noise
// --noise DN), every view reconstructed from its fringe images with the true rig
// (ViewReconstructor), its markers detected in the decoded textures (DetectViewMarkers, not taken
// from the truth), then fringe::registration::RegisterViews. Pose errors at three stages: after
// marker matching (marker_*), after the global marker adjustment (adjusted_*), after multi-level
// multi-view ICP (icp_*). Gauge: the one rigid G minimising, over all placed views together, the
// squared displacement of each view's own points (a seeded sample of <= 2000 per view) between
// G * estimated world_from_sensor and the true pose; then per view the rotation error is the
// angle of R_true^T R_(G est) and the translation error the displacement of the view's cloud
// centroid; max and RMS over views (the world view included: it is not exempt from the gauge).
//   icp_improvement      RMS centroid displacement after markers / after ICP;
//   registered_rms_mm    RMS distance of the registered points (final poses, gauge removed) to
//                        the truth mesh, points within 2 mm;
//   marker_match_rate    fraction of detected markers whose triangulated centre lies within
//                        1 mm of a true marker centre of that view (a wrong stereo match lands
//                        far off the surface or on another marker);
//   open3d_*             Open3D RegistrationICP point-to-plane from the same initial poses (the
//                        adjusted ones), each non-world view against the union of the others at
//                        their initial poses, threshold = ours' first; open3d_ms_* its
//                        multi-scale variant (voxel 2, 1, 0.5 mm; threshold halved per scale);
//   ours_icp_s, open3d_icp_s, open3d_ms_icp_s  wall time of those refinements.
// Stanford bunny (real scans, no markers; ../shared/data/stanford-bunny): bun045 onto bun000,
// reference bun.conf (p_common = R^T p_scan + t, quaternion x y z w; see the data's README):
//   bunny_*              ours (AlignPointToPlane) from the reference perturbed by 5 deg / 5 mm;
//   open3d_bunny_*       Open3D RegistrationICP point-to-plane from the same start;
//   bunny_coarse_*       from no initial pose: Open3D FPFH + RANSAC (AlignCoarse), then ours.
// Bunny errors: rotation angle and displacement of bun045's centroid, against bun.conf (itself
// good to ~0.05-0.1 deg: agreement, not accuracy).
//
// Usage: bench_registration [--json] [--views 8] [--scale 1] [--noise 1.5] [--seed 1]
//                           [--bunny DIR] [--no-bunny] [--cache DIR] [--no-open3d]
//                           [--icp-points N...] [--icp-degeneracy R] [--no-adjustment]
//                           [--no-icp] [--icp-shrink-within-level 0|1]
//                           [--icp-normal-space 0|1] [--icp-step-sigmas S] [--icp-trim F]
//                           [--no-markers [--start-slide-mm D]]
// --cache DIR keeps the reconstructed views (organized PLY + markers file per view, and the
// marker-match counts) and reuses them on the next run with the same arguments: registration
// experiments then skip the minutes of simulation. The PLY stores float coordinates (~6e-5 mm).
// --start-slide-mm D (with --no-markers) starts every view but the first from its true pose
// moved by D mm in a seeded direction: the final multi-view ICP of marker-free views measured
// on its own, in seconds, without the pairwise stage.
#include <open3d/geometry/KDTreeSearchParam.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/pipelines/registration/GlobalOptimization.h>
#include <open3d/pipelines/registration/PoseGraph.h>
#include <open3d/pipelines/registration/Registration.h>
#include <open3d/pipelines/registration/TransformationEstimation.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "bench_timing.h"
#include "fringe/eval/deviation.h"
#include "fringe/geometry/align.h"
#include "fringe/geometry/point_index.h"
#include "fringe/io/json.h"
#include "fringe/io/ply.h"
#include "fringe/registration/coarse.h"
#include "fringe/registration/icp.h"
#include "fringe/registration/markers.h"
#include "fringe/registration/register_views.h"
#include "fringe/registration/registration_io.h"
#include "fringe/sim/scan.h"
#include "fringe/stereo/reconstruct_view.h"
#include "fringe/util/error.h"
#include "fringe/util/random.h"
#include "fringe/util/timer.h"
#include "simulated_scan.h"

namespace fringe {
namespace {

namespace fs = std::filesystem;
namespace o3reg = open3d::pipelines::registration;
using Eigen::Vector3d;

struct PoseStats {
  double max_rot_deg = 0, rms_rot_deg = 0, max_trans_mm = 0, rms_trans_mm = 0;
};

Vector3d Centroid(const PointCloud& c) {
  Vector3d s = Vector3d::Zero();
  for (const Vector3d& p : c.points) s += p;
  return s / static_cast<double>(std::max<size_t>(1, c.size()));
}

// Gauge G (see the header) from a seeded sample of each view's points.
Rigid3d Gauge(const std::vector<Rigid3d>& est, const std::vector<Rigid3d>& truth,
              const std::vector<PointCloud>& clouds, const std::vector<bool>& use) {
  std::vector<Vector3d> a, b;
  std::mt19937_64 rng(7);
  for (size_t v = 0; v < est.size(); ++v) {
    if (!use[v] || clouds[v].empty()) continue;
    std::uniform_int_distribution<size_t> pick(0, clouds[v].size() - 1);
    for (int k = 0; k < 2000; ++k) {
      const Vector3d& p = clouds[v].points[pick(rng)];
      a.push_back(est[v] * p);
      b.push_back(truth[v] * p);
    }
  }
  const RigidAlignment g = AlignRigid(a, b);
  if (!g.ok()) throw Error("bench_registration: gauge fit failed: " + g.message);
  return g.b_from_a;
}

PoseStats Errors(const std::vector<Rigid3d>& est, const std::vector<Rigid3d>& truth,
                 const std::vector<PointCloud>& clouds, const std::vector<bool>& use) {
  const Rigid3d g = Gauge(est, truth, clouds, use);
  PoseStats s;
  int n = 0;
  for (size_t v = 0; v < est.size(); ++v) {
    if (!use[v]) continue;
    const Rigid3d e = g * est[v];
    const double rot = (truth[v].rotation().inverse() * e.rotation())
                           .angularDistance(Eigen::Quaterniond::Identity()) *
                       180 / M_PI;
    const Vector3d c = Centroid(clouds[v]);
    const double tr = (e * c - truth[v] * c).norm();
    // NaN-propagating max: a pose that went non-finite must not vanish from the figure.
    s.max_rot_deg =
        std::isnan(rot) || std::isnan(s.max_rot_deg) ? NAN : std::max(s.max_rot_deg, rot);
    s.max_trans_mm =
        std::isnan(tr) || std::isnan(s.max_trans_mm) ? NAN : std::max(s.max_trans_mm, tr);
    s.rms_rot_deg += rot * rot;
    s.rms_trans_mm += tr * tr;
    ++n;
  }
  s.rms_rot_deg = std::sqrt(s.rms_rot_deg / std::max(1, n));
  s.rms_trans_mm = std::sqrt(s.rms_trans_mm / std::max(1, n));
  return s;
}

// Detected marker centres against the truth, split along the left camera's viewing ray (the
// triangulation's depth direction) and across it; sigma_ratio = RMS error / RMS predicted sigma.
struct MarkerCentreErrors {
  double ss = 0, ss_depth = 0, sum_depth = 0, ss_lateral = 0, ss_sigma = 0;
  int n = 0;
  void Add(const Vector3d& error, const Vector3d& true_centre, double sigma_mm) {
    const Vector3d ray = true_centre.normalized();
    const double depth = error.dot(ray);
    ss += error.squaredNorm();
    ss_depth += depth * depth;
    sum_depth += depth;
    ss_lateral += (error - depth * ray).squaredNorm();
    ss_sigma += sigma_mm * sigma_mm;
    ++n;
  }
};

nlohmann::json ToJson(const MarkerCentreErrors& e) {
  const double k = 1.0 / std::max(1, e.n);
  return {{"marker_centre_rms_mm", std::sqrt(e.ss * k)},
          {"marker_depth_rms_mm", std::sqrt(e.ss_depth * k)},
          {"marker_depth_bias_mm", e.sum_depth * k},
          {"marker_lateral_rms_mm", std::sqrt(e.ss_lateral * k)},
          {"marker_sigma_ratio", std::sqrt(e.ss / std::max(1e-30, e.ss_sigma))}};
}

std::shared_ptr<open3d::geometry::PointCloud> ToOpen3d(const PointCloud& c, const Rigid3d& pose) {
  auto o = std::make_shared<open3d::geometry::PointCloud>();
  o->points_.reserve(c.size());
  o->normals_.reserve(c.size());
  for (size_t i = 0; i < c.size(); ++i) {
    // The points our ICP uses too: finite, with a finite unit normal (a reconstructed grid has
    // a few points whose normal could not be estimated; Open3D would turn them into NaN poses).
    if (!c.points[i].allFinite() || !c.normals[i].allFinite() ||
        std::abs(c.normals[i].norm() - 1) > 1e-3) {
      continue;
    }
    o->points_.push_back(pose * c.points[i]);
    o->normals_.push_back(pose.RotateDirection(c.normals[i]));
  }
  return o;
}

Rigid3d FromMatrix(const Eigen::Matrix4d& m) {
  return Rigid3d(Eigen::Quaterniond(Eigen::Matrix3d(m.block<3, 3>(0, 0))).normalized(),
                 m.block<3, 1>(0, 3));
}

// Open3D point-to-plane ICP of `source` onto `target`; multi-scale: voxel 2, 1, 0.5 mm with the
// threshold halved per scale.
Rigid3d Open3dIcp(const PointCloud& source, const open3d::geometry::PointCloud& target,
                  const Rigid3d& start, double threshold_mm, bool multi_scale) {
  const auto src = ToOpen3d(source, Rigid3d());
  Eigen::Matrix4d t = start.ToMatrix4();
  const o3reg::ICPConvergenceCriteria crit(1e-7, 1e-7, 30);
  if (!multi_scale) {
    return FromMatrix(o3reg::RegistrationICP(*src, target, threshold_mm, t,
                                             o3reg::TransformationEstimationPointToPlane(), crit)
                          .transformation_);
  }
  double thr = threshold_mm;
  for (double voxel : {2.0, 1.0, 0.5}) {
    const auto s = src->VoxelDownSample(voxel);
    const auto d = target.VoxelDownSample(voxel);
    t = o3reg::RegistrationICP(*s, *d, thr, t, o3reg::TransformationEstimationPointToPlane(), crit)
            .transformation_;
    thr /= 2;
  }
  return FromMatrix(t);
}

// bun.conf: "bmesh FILE tx ty tz qx qy qz qw"; common_from_scan = (R^T, t) in mm.
Rigid3d BunnyPose(const fs::path& conf, const std::string& file) {
  std::ifstream in(conf);
  if (!in) throw Error("bench_registration: cannot read " + conf.string());
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ss(line);
    std::string tag, name;
    double tx, ty, tz, qx, qy, qz, qw;
    if (ss >> tag >> name >> tx >> ty >> tz >> qx >> qy >> qz >> qw && tag == "bmesh" &&
        name == file) {
      const Eigen::Quaterniond q(qw, qx, qy, qz);
      return Rigid3d(q.normalized().inverse(), 1000 * Vector3d(tx, ty, tz));
    }
  }
  throw Error("bench_registration: " + conf.string() + " has no line for " + file);
}

std::pair<double, double> PairError(const Rigid3d& est, const Rigid3d& truth, const Vector3d& c) {
  return {(truth.rotation().inverse() * est.rotation())
                  .angularDistance(Eigen::Quaterniond::Identity()) *
              180 / M_PI,
          (est * c - truth * c).norm()};
}

// The four bunny scans of the shared data, in millimetres, with bun.conf's poses relative to
// bun000 (the registration's world: the first view).
const std::vector<std::string> kBunnyScans = {"bun000", "bun045", "bun090", "bun315"};

// Pooled point-to-plane residual of the overlapping pairs at the given poses: for every ordered
// pair (v, u), every 4th point of v with a point of u within 1 mm (the scans' spacing is
// ~0.5 mm, their noise ~0.1-0.2 mm) gives n_u . (p_v - p_u); RMS over all such pairs.
// Also the number of such residuals (a view placed far off pairs with nothing and drops out).
std::pair<double, int64_t> PooledPairRms(const std::vector<PointCloud>& clouds,
                                         const std::vector<Rigid3d>& poses) {
  std::vector<PointIndex> index;
  for (size_t u = 0; u < clouds.size(); ++u) {
    std::vector<Vector3d> pts;
    for (const Vector3d& p : clouds[u].points) pts.push_back(poses[u] * p);
    index.emplace_back(std::move(pts));
  }
  double ss = 0;
  int64_t n = 0;
  for (size_t v = 0; v < clouds.size(); ++v) {
    for (size_t u = 0; u < clouds.size(); ++u) {
      if (u == v) continue;
      for (size_t i = 0; i < clouds[v].size(); i += 4) {
        const Vector3d p = poses[v] * clouds[v].points[i];
        const auto [k, d2] = index[u].Nearest(p);
        if (d2 > 1.0) continue;
        const Vector3d nu = poses[u].RotateDirection(clouds[u].normals[k]);
        if (!nu.allFinite()) continue;
        const double r = nu.dot(p - index[u].point(k));
        ss += r * r;
        ++n;
      }
    }
  }
  return {std::sqrt(ss / std::max<int64_t>(1, n)), n};
}

// Max rotation (deg) and centroid displacement (mm) of views 1.. against the reference, view 0
// the gauge (both are in view 0's frame); views not placed count as NaN.
std::pair<double, double> MaxViewError(const std::vector<Rigid3d>& est,
                                       const std::vector<Rigid3d>& ref,
                                       const std::vector<PointCloud>& clouds,
                                       const std::vector<bool>& placed) {
  double rot = 0, tr = 0;
  for (size_t v = 1; v < est.size(); ++v) {
    if (!placed[v]) return {NAN, NAN};
    const auto [r, t] = PairError(est[v], ref[v], Centroid(clouds[v]));
    rot = std::max(rot, r);
    tr = std::max(tr, t);
  }
  return {rot, tr};
}

// Open3D's multiway registration (its tutorial's pipeline): pairwise point-to-plane ICP of every
// pair from the starting poses (15 mm, then 1.5 mm), a pose graph (consecutive pairs as
// odometry (`odometry`: pairs (t, s), t < s, of neighbouring scans; its tutorial's are
// consecutive captures), the others as uncertain loop closures, information from the fine ICP) and
// its global optimisation (Levenberg-Marquardt, line process), node 0 the reference.
std::vector<Rigid3d> Open3dMultiway(const std::vector<PointCloud>& clouds,
                                    const std::vector<Rigid3d>& start,
                                    const std::vector<std::pair<int, int>>& odometry) {
  std::vector<std::shared_ptr<open3d::geometry::PointCloud>> pc;
  for (const PointCloud& c : clouds) pc.push_back(ToOpen3d(c, Rigid3d()));
  o3reg::PoseGraph graph;
  for (const Rigid3d& s : start) graph.nodes_.emplace_back(s.ToMatrix4());
  const o3reg::ICPConvergenceCriteria crit(1e-7, 1e-7, 30);
  for (size_t t = 0; t < clouds.size(); ++t) {
    for (size_t s = t + 1; s < clouds.size(); ++s) {
      // Open3D's edge (source s, target t) carries t_from_s.
      Eigen::Matrix4d init = (start[t].Inverse() * start[s]).ToMatrix4();
      const auto coarse = o3reg::RegistrationICP(
          *pc[s], *pc[t], 15.0, init, o3reg::TransformationEstimationPointToPlane(), crit);
      const auto fine = o3reg::RegistrationICP(*pc[s], *pc[t], 1.5, coarse.transformation_,
                                               o3reg::TransformationEstimationPointToPlane(), crit);
      const Eigen::Matrix6d info =
          o3reg::GetInformationMatrixFromPointClouds(*pc[s], *pc[t], 1.5, fine.transformation_);
      graph.edges_.emplace_back(
          static_cast<int>(s), static_cast<int>(t), fine.transformation_, info,
          std::find(odometry.begin(), odometry.end(),
                    std::make_pair(static_cast<int>(t), static_cast<int>(s))) == odometry.end());
    }
  }
  o3reg::GlobalOptimization(graph, o3reg::GlobalOptimizationLevenbergMarquardt(),
                            o3reg::GlobalOptimizationConvergenceCriteria(),
                            o3reg::GlobalOptimizationOption(1.5, 0.25, 1.0, 0));
  std::vector<Rigid3d> out;
  const Rigid3d inv0 = FromMatrix(graph.nodes_[0].pose_).Inverse();
  for (const auto& node : graph.nodes_) out.push_back(inv0 * FromMatrix(node.pose_));
  return out;
}

int Run(int argc, char** argv) {
  CLI::App app{"Multi-view registration: accuracy vs truth and Open3D, speed (issue 11)"};
  bool json = false, no_bunny = false;
  int views_n = 8;
  double scale = 1.0, noise_dn = 1.5;  // below ~1 the 5 mm markers are too few pixels
  uint64_t seed = 1;
  std::string bunny_dir, cache_dir;
  if (const char* d = std::getenv("FRINGE_SHARED_DATA")) {
    bunny_dir = (fs::path(d) / "stanford-bunny").string();
  } else {
    bunny_dir = "../shared/data/stanford-bunny";
  }
  app.add_flag("--json", json, "Print one JSON object");
  app.add_option("--views", views_n, "Views around the part (>= 3)")->capture_default_str();
  app.add_option("--scale", scale, "Rig resolution scale (1: 1280x1024 cameras)")
      ->capture_default_str();
  app.add_option("--noise", noise_dn, "Camera read noise, DN")->capture_default_str();
  app.add_option("--seed", seed, "Scene, poses and noise seed")->capture_default_str();
  app.add_option("--bunny", bunny_dir, "Stanford bunny folder (bun000.ply, bun045.ply, bun.conf)")
      ->capture_default_str();
  app.add_flag("--no-bunny", no_bunny, "Skip the bunny");
  bool bunny_only = false;
  app.add_flag("--bunny-only", bunny_only, "Only the bunny (no simulated views)");
  int bunny_repeats = 3;
  app.add_option("--bunny-repeats", bunny_repeats,
                 "Timed runs of each bunny ICP (median wall, mean CPU), >= 1")
      ->capture_default_str();
  registration::RegistrationOptions options;
  bool no_open3d = false, no_adjustment = false;
  app.add_option("--icp-points", options.icp.points_per_level,
                 "ICP samples per view, one number per level (experiments)")
      ->capture_default_str();
  app.add_option("--icp-degeneracy", options.icp.degeneracy_ratio,
                 "ICP directions weaker than this x the strongest stay at the marker poses")
      ->capture_default_str();
  app.add_option("--icp-shrink-within-level", options.icp.shrink_within_level,
                 "ICP threshold shrinks after every iteration (1) or once per level (0)")
      ->capture_default_str();
  app.add_option("--icp-normal-space", options.icp.normal_space_sampling,
                 "ICP samples in normal-space order (1) or uniformly (0)")
      ->capture_default_str();
  app.add_option("--icp-normal-spread-deg", options.icp.sample_max_normal_spread_deg,
                 "ICP samples only points whose neighbours' normals lie within this angle "
                 "(0: all points)")
      ->capture_default_str();
  app.add_option("--pair-normal-spread-deg", options.coarse_icp_normal_spread_deg,
                 "Marker-free pairwise ICP samples only points whose neighbours' normals lie "
                 "within this angle (0: all points)")
      ->capture_default_str();
  app.add_option("--coarse-voxel-mm", options.coarse.voxel_mm,
                 "Marker-free FPFH + RANSAC downsampling voxel, mm (registration::CoarseOptions)")
      ->capture_default_str();
  app.add_option("--coarse-hypotheses", options.coarse.hypotheses,
                 "Marker-free sequential RANSAC runs per pair (registration::CoarseOptions)")
      ->capture_default_str();
  app.add_option("--ransac-score-samples", options.coarse.score_samples,
                 "Marker-free RANSAC scores each hypothesis on this many source samples (a "
                 "number above the samples: all, as Open3D)")
      ->capture_default_str();
  app.add_option("--icp-max-iterations", options.icp.max_iterations_per_level,
                 "ICP iterations per level at most")
      ->capture_default_str();
  app.add_option("--free-icp-trim", options.marker_free_icp.trim_fraction,
                 "The marker-free refinement keeps this fraction of each view pair's "
                 "correspondences")
      ->capture_default_str();
  app.add_option("--free-icp-normal-deg", options.marker_free_icp.max_normal_angle_deg,
                 "The marker-free refinement pairs normals within this angle")
      ->capture_default_str();
  app.add_option("--free-icp-spread-deg", options.marker_free_icp.sample_max_normal_spread_deg,
                 "The marker-free refinement samples points whose neighbours' normals are within "
                 "this angle (0: every point)")
      ->capture_default_str();
  app.add_option("--free-icp-tangential", options.marker_free_icp.max_tangential_spacings,
                 "The marker-free refinement's coverage test, in target spacings (0: off)")
      ->capture_default_str();
  app.add_option("--icp-trim", options.icp.trim_fraction,
                 "ICP keeps this fraction of each view pair's correspondences (the closest)")
      ->capture_default_str();
  app.add_option("--icp-step-sigmas", options.icp.convergence_step_sigmas,
                 "ICP level converged when a step is below this many sigmas of the estimate")
      ->capture_default_str();
  app.add_option("--icp-projective-from-level", options.icp.projective_from_level,
                 "ICP associates projectively on the grids from this level on (k-d tree before; "
                 "a value >= the levels: never)")
      ->capture_default_str();
  app.add_option("--icp-window", options.icp.projective_window_px,
                 "Projective association window half-size, px")
      ->capture_default_str();
  app.add_option("--icp-sample-fixed", options.icp.sample_fixed_views,
                 "ICP samples the fixed (world) view too (1) or only the free views (0)")
      ->capture_default_str();
  bool no_markers = false;
  app.add_flag("--no-markers", no_markers,
               "Ignore the markers: every view is placed marker-free (FPFH + RANSAC + ICP)");
  app.add_flag("--no-adjustment", no_adjustment, "Skip the global marker adjustment");
  bool no_icp = false;
  app.add_flag("--no-icp", no_icp, "Skip the ICP (marker stages only; icp_* = adjusted)");
  app.add_flag("--no-open3d", no_open3d, "Skip the Open3D comparison");
  double start_slide_mm = -1;
  app.add_option("--start-slide-mm", start_slide_mm,
                 "With --no-markers: every view starts from its true pose slid by this much "
                 "(seeded direction per view), the refinement alone measured (< 0: no start)");
  app.add_option("--cache", cache_dir,
                 "Keep the reconstructed views here and reuse them (same arguments only)");
  CLI11_PARSE(app, argc, argv);
  if (views_n < 3) throw Error("bench_registration: --views must be >= 3");
  if (bunny_only && no_bunny) throw Error("bench_registration: --bunny-only and --no-bunny");
  if (bunny_repeats < 1) throw Error("bench_registration: --bunny-repeats must be >= 1");
  nlohmann::json j = nlohmann::json::object();
  if (!bunny_only) {
    // Simulate, reconstruct, detect markers.
    bench::SimulatedScanOptions scan_options;
    scan_options.views = views_n;
    scan_options.rig_scale = scale;
    scan_options.noise_dn = noise_dn;
    scan_options.seed = seed;
    const bench::SimulatedScan scan(scan_options);
    const StereoRig& rig = scan.rig();
    const sim::ScanSimulator& simulator = scan.simulator();
    const stereo::ViewReconstructor& reconstructor = scan.reconstructor();
    std::vector<registration::RegistrationView> views;
    std::vector<PointCloud> clouds;
    int detected = 0, correct = 0;
    util::Timer sim_timer;
    const fs::path cache(cache_dir);
    const std::string cache_key = "views" + std::to_string(views_n) + "_scale" +
                                  std::to_string(scale) + "_noise" + std::to_string(noise_dn) +
                                  "_seed" + std::to_string(seed);
    const fs::path cache_stats = cache / (cache_key + ".json");
    const bool from_cache = !cache_dir.empty() && fs::exists(cache_stats);
    for (int v = 0; from_cache && v < views_n; ++v) {
      const fs::path stem = cache / (cache_key + "_" + std::to_string(v));
      registration::RegistrationView rv;
      rv.name = std::to_string(v);
      const OrganizedPointCloud grid = io::ReadOrganizedPly(stem.string() + ".ply");
      rv.cloud = grid.Compact();
      rv.grid = registration::IndexViewGrid(grid);
      rv.markers = registration::ReadViewMarkers(stem.string() + ".markers.json");
      clouds.push_back(rv.cloud);
      views.push_back(std::move(rv));
    }
    if (from_cache) {
      const nlohmann::json stats = io::ReadJson(cache_stats);
      detected = stats.at("detected").get<int>();
      correct = stats.at("correct").get<int>();
    }
    for (int v = 0; !from_cache && v < views_n; ++v) {
      const sim::ViewImages images = simulator.RenderView(v);
      const stereo::ViewReconstruction rec =
          reconstructor.Reconstruct(images.left.images, images.right.images);
      registration::RegistrationView rv;
      rv.name = std::to_string(v);
      rv.cloud = rec.cloud.Compact();
      rv.grid = registration::IndexViewGrid(rec.cloud);
      rv.markers =
          registration::DetectViewMarkers(rig, rec.texture_left, rec.texture_right, rec.cloud)
              .markers;
      for (const registration::ViewMarker& m : rv.markers) {
        ++detected;
        for (const sim::MarkerObservation& o : images.markers) {
          if ((o.centre_in_sensor - m.centre_in_sensor).norm() < 1.0) {
            ++correct;
            break;
          }
        }
      }
      if (!cache_dir.empty()) {
        fs::create_directories(cache);
        const fs::path stem = cache / (cache_key + "_" + std::to_string(v));
        io::WritePly(stem.string() + ".ply", rec.cloud);
        registration::WriteViewMarkers(stem.string() + ".markers.json", rv.markers);
      }
      clouds.push_back(rv.cloud);
      views.push_back(std::move(rv));
    }
    if (!cache_dir.empty() && !from_cache) {
      io::WriteJson(cache_stats, {{"detected", detected}, {"correct", correct}});
    }
    const double sim_s = sim_timer.ElapsedSeconds();
    const std::vector<Rigid3d>& truth = simulator.view_poses();

    // Every detected marker's true identity: the scene marker whose centre (moved into the view's
    // sensor frame by the true pose) lies within 1 mm, else -1 (a wrong stereo match or a blob
    // that is no marker). From the scene, so cached views are checked the same way.
    const std::vector<sim::Marker>& scene_markers = simulator.scene().markers();
    std::vector<std::vector<int>> truth_id(views_n);
    MarkerCentreErrors centre_errors;
    for (int v = 0; v < views_n; ++v) {
      const Rigid3d sensor_from_world = truth[v].Inverse();
      for (const registration::ViewMarker& m : views[v].markers) {
        int id = -1;
        double best = 1.0;
        Vector3d true_centre = Vector3d::Zero();
        for (const sim::Marker& t : scene_markers) {
          const Vector3d c = sensor_from_world * t.centre_in_world;
          const double d = (c - m.centre_in_sensor).norm();
          if (d < best) {
            best = d;
            id = t.id;
            true_centre = c;
          }
        }
        truth_id[v].push_back(id);
        if (id >= 0) centre_errors.Add(m.centre_in_sensor - true_centre, true_centre, m.sigma_mm);
      }
    }

    if (no_markers && start_slide_mm >= 0) {
      std::mt19937_64 rng(seed + 7);
      std::normal_distribution<double> gauss;
      for (int v = 0; v < views_n; ++v) {
        const Vector3d dir = Vector3d(gauss(rng), gauss(rng), gauss(rng)).normalized();
        views[v].initial_world_from_sensor =
            Rigid3d(Eigen::Quaterniond::Identity(), start_slide_mm * (v > 0) * dir) *
            truth[0].Inverse() * truth[v];
      }
    }
    options.use_markers = !no_markers;
    options.adjust_markers = !no_adjustment;
    options.refine_icp = !no_icp;
    options.Check();
    util::CpuTimer register_cpu;
    const registration::RegistrationResult r = registration::RegisterViews(views, options);
    const double register_cpu_s = register_cpu.ElapsedSeconds();
    std::vector<bool> placed(views_n);
    std::vector<Rigid3d> markers_est, adjusted_est, final_est;
    for (int v = 0; v < views_n; ++v) {
      placed[v] = r.views[v].placed();
      markers_est.push_back(r.views[v].world_from_sensor_markers);
      adjusted_est.push_back(r.views[v].world_from_sensor_adjusted);
      final_est.push_back(r.views[v].world_from_sensor);
    }
    const PoseStats em = Errors(markers_est, truth, clouds, placed);
    const PoseStats ea = Errors(adjusted_est, truth, clouds, placed);
    const PoseStats ei = Errors(final_est, truth, clouds, placed);

    // Registered points against the truth mesh.
    const Rigid3d g = Gauge(final_est, truth, clouds, placed);
    const MeshIndex mesh(simulator.scene().CombinedMesh());
    double ss = 0;
    int64_t n = 0;
    for (int v = 0; v < views_n; ++v) {
      if (!placed[v]) continue;
      const Rigid3d pose = g * final_est[v];
      for (size_t i = 0; i < clouds[v].size(); i += 4) {
        const double d = mesh.SignedDistance(pose * clouds[v].points[i], 2.0);
        if (std::isfinite(d)) {
          ss += d * d;
          ++n;
        }
      }
    }
    const double registered_rms = std::sqrt(ss / std::max<int64_t>(1, n));

    // Open3D from the same initial (adjusted) poses, the same first threshold.
    double start_threshold =
        r.summary.icp.levels.empty() ? 1.0 : r.summary.icp.levels.front().threshold_start_mm;
    std::vector<Rigid3d> o3d_est = adjusted_est, o3d_ms_est = adjusted_est;
    double o3d_s = 0, o3d_ms_s = 0;
    int world = -1;
    for (int v = 0; v < views_n; ++v) {
      if (r.views[v].path == registration::ViewPath::kWorld) world = v;
    }
    for (int v = 0; v < views_n && !no_open3d; ++v) {
      if (!placed[v] || v == world) continue;
      open3d::geometry::PointCloud target;
      for (int u = 0; u < views_n; ++u) {
        if (u != v && placed[u]) target += *ToOpen3d(clouds[u], adjusted_est[u]);
      }
      util::Timer t;
      o3d_est[v] = Open3dIcp(clouds[v], target, adjusted_est[v], start_threshold, false);
      o3d_s += t.ElapsedSeconds();
      util::Timer t2;
      o3d_ms_est[v] = Open3dIcp(clouds[v], target, adjusted_est[v], start_threshold, true);
      o3d_ms_s += t2.ElapsedSeconds();
    }
    const PoseStats eo = Errors(o3d_est, truth, clouds, placed);

    // Distance-invariance matching against the truth: every sighting after a map marker's first
    // is a correspondence the matcher made (view marker -> map marker); it is correct when both
    // carry the same true identity. "missed": two map markers of one true marker (a shared
    // marker the matcher left out; not wrong, but it weakens the map).
    int di_pairs = 0, di_correct = 0, di_missed = 0;
    std::map<int, int> map_markers_of_truth;
    for (const registration::MapMarker& m : r.map) {
      if (m.sightings.empty()) continue;
      const int first = truth_id[m.sightings[0].view][m.sightings[0].view_marker];
      if (first >= 0 && ++map_markers_of_truth[first] > 1) ++di_missed;
      for (size_t k = 1; k < m.sightings.size(); ++k) {
        ++di_pairs;
        di_correct +=
            first >= 0 && truth_id[m.sightings[k].view][m.sightings[k].view_marker] == first;
      }
    }
    const PoseStats eom = Errors(o3d_ms_est, truth, clouds, placed);

    j = {{"views", views_n},
         {"scale", scale},
         {"cameras_px", {rig.left.width, rig.left.height}},
         {"noise_dn", noise_dn},
         {"placed", r.summary.placed},
         {"registration_status", registration::ToString(r.summary.status)},
         {"paths", nlohmann::json::array()},
         {"markers_detected", detected},
         {"marker_match_rate", detected > 0 ? static_cast<double>(correct) / detected : 0.0},
         {"distance_invariance_pairs", di_pairs},
         {"distance_invariance_match_rate",
          di_pairs > 0 ? static_cast<double>(di_correct) / di_pairs : 0.0},
         {"distance_invariance_missed", di_missed},
         {"marker_rot_err_deg", em.max_rot_deg},
         {"marker_trans_err_mm", em.max_trans_mm},
         {"marker_rms_rot_err_deg", em.rms_rot_deg},
         {"marker_rms_trans_err_mm", em.rms_trans_mm},
         {"adjusted_rot_err_deg", ea.max_rot_deg},
         {"adjusted_trans_err_mm", ea.max_trans_mm},
         {"adjusted_rms_trans_err_mm", ea.rms_trans_mm},
         {"icp_rot_err_deg", ei.max_rot_deg},
         {"icp_trans_err_mm", ei.max_trans_mm},
         {"icp_rms_rot_err_deg", ei.rms_rot_deg},
         {"icp_rms_trans_err_mm", ei.rms_trans_mm},
         {"icp_improvement", em.rms_trans_mm / std::max(1e-12, ei.rms_trans_mm)},
         {"registered_rms_mm", registered_rms},
         {"open3d_rot_err_deg", eo.max_rot_deg},
         {"open3d_trans_err_mm", eo.max_trans_mm},
         {"open3d_ms_rot_err_deg", eom.max_rot_deg},
         {"open3d_ms_trans_err_mm", eom.max_trans_mm},
         {"ours_icp_s", r.summary.icp.seconds},
         {"open3d_icp_s", o3d_s},
         {"open3d_ms_icp_s", o3d_ms_s},
         {"open3d_time_ratio", o3d_s / std::max(1e-9, r.summary.icp.seconds)},
         {"register_s", r.summary.seconds},
         {"register_cpu_s", register_cpu_s},
         {"simulate_reconstruct_s", sim_s},
         {"icp", r.summary.icp.BriefReport()}};
    j.update(ToJson(centre_errors));
    if (no_markers) {
      // A placed view is wrong when, after the refinement, it is off by more than 0.1 deg or
      // 1 mm (ten and fifty times the targets): then it is not merely inaccurate.
      int wrong = 0;
      const Rigid3d gauge = Gauge(final_est, truth, clouds, placed);
      for (int v = 0; v < views_n; ++v) {
        if (!placed[v]) continue;
        const auto [rot, tr] = PairError(gauge * final_est[v], truth[v], Centroid(clouds[v]));
        wrong += !(rot <= 0.1 && tr <= 1.0);
      }
      j.update({{"no_markers_views", views_n},
                {"no_markers_placed", r.summary.placed},
                {"no_markers_wrong", wrong},
                {"no_markers_rot_err_deg", ei.max_rot_deg},
                {"no_markers_trans_err_mm", ei.max_trans_mm}});
    }
    for (const auto& v : r.views) {
      j["paths"].push_back(registration::ToString(v.path));
      j["view_messages"].push_back(v.message);
    }
  }  // !bunny_only

  if (!no_bunny) {
    const fs::path dir(bunny_dir);
    if (!fs::exists(dir / "bun.conf")) {
      throw Error("bench_registration: " + dir.string() +
                  " has no bun.conf (give --bunny DIR or --no-bunny)");
    }
    std::string note;
    const registration::RegistrationView b0 =
        registration::ReadRegistrationView(dir / "bun000.ply", 1000, false, &note);
    const registration::RegistrationView b45 =
        registration::ReadRegistrationView(dir / "bun045.ply", 1000, false, &note);
    const Rigid3d ref = BunnyPose(dir / "bun.conf", "bun000.ply").Inverse() *
                        BunnyPose(dir / "bun.conf", "bun045.ply");  // 000_from_045
    const Vector3d c = Centroid(b45.cloud);
    const Rigid3d turn = Rigid3d::FromAxisAngle(Vector3d(1, 2, -1).normalized(), 5 * M_PI / 180);
    const Vector3d cw = ref * c;
    const Rigid3d start = Rigid3d(turn.rotation(), cw - turn.RotateDirection(cw) +
                                                       5 * Vector3d(-1, 1, 1).normalized()) *
                          ref;
    registration::IcpOptions io;
    io.initial_threshold_mm = 15;  // 5 deg at the bunny's ~60 mm lever plus 5 mm
    // Median wall and mean CPU time of bunny_repeats runs each after a warm-up (a 0.7 s pair
    // on a shared machine); Open3D's target conversion is timed with it, as our preparation
    // (usable points, k-d tree) is with ours.
    registration::IcpResult ours;
    const auto run_ours = [&] {
      ours = registration::AlignPointToPlane(b45.cloud, b0.cloud, start, io);
    };
    Rigid3d o3d;
    const auto run_o3d = [&] {
      const auto target = ToOpen3d(b0.cloud, Rigid3d());
      o3d = Open3dIcp(b45.cloud, *target, start, io.initial_threshold_mm, false);
    };
    const double ours_s = 1e-3 * bench::TimeMs(bunny_repeats, run_ours);
    const double ours_cpu_s = 1e-3 * bench::CpuMsPerRun(bunny_repeats, run_ours);
    const double o3d_bs = 1e-3 * bench::TimeMs(bunny_repeats, run_o3d);
    const double o3d_cpu_s = 1e-3 * bench::CpuMsPerRun(bunny_repeats, run_o3d);
    const auto [br, bt] = PairError(ours.world_from_sensor[1], ref, c);
    const auto [obr, obt] = PairError(o3d, ref, c);
    const registration::CoarseResult coarse = registration::AlignCoarse(b45.cloud, b0.cloud);
    double cr = NAN, ct = NAN;
    if (coarse.ok()) {
      registration::IcpOptions co;
      co.initial_threshold_mm = 3 * registration::CoarseOptions().voxel_mm;
      const registration::IcpResult ci =
          registration::AlignPointToPlane(b45.cloud, b0.cloud, coarse.target_from_source, co);
      std::tie(cr, ct) = PairError(ci.world_from_sensor[1], ref, c);
    }
    j.update({{"bunny_rot_err_deg", br},
              {"bunny_trans_err_mm", bt},
              {"bunny_icp_s", ours_s},
              {"bunny_icp_cpu_s", ours_cpu_s},
              {"bunny_icp", ours.summary.BriefReport()},
              {"open3d_bunny_rot_err_deg", obr},
              {"open3d_bunny_trans_err_mm", obt},
              {"open3d_bunny_icp_s", o3d_bs},
              {"open3d_bunny_icp_cpu_s", o3d_cpu_s},
              {"open3d_bunny_time_ratio", o3d_bs / std::max(1e-9, ours_s)},
              {"bunny_coarse_status", registration::ToString(coarse.status)},
              {"bunny_coarse_rot_err_deg", cr},
              {"bunny_coarse_trans_err_mm", ct}});

    // The four scans registered together (RegisterViews, no markers, unorganized clouds):
    // from no initial pose (bunny_free_*), and from bun.conf's poses each turned by 5 deg about
    // its centroid and moved 5 mm (bunny_start_*), beside Open3D's multiway registration from
    // the same starts. Errors against bun.conf (a reference, not the truth), max over the views.
    std::vector<registration::RegistrationView> bv;
    std::vector<PointCloud> bclouds;
    std::vector<Rigid3d> bref;
    const Rigid3d conf0 = BunnyPose(dir / "bun.conf", "bun000.ply");
    for (const std::string& name : kBunnyScans) {
      bv.push_back(registration::ReadRegistrationView(dir / (name + ".ply"), 1000, false, &note));
      bclouds.push_back(bv.back().cloud);
      bref.push_back(conf0.Inverse() * BunnyPose(dir / "bun.conf", name + ".ply"));
    }
    registration::RegistrationOptions bo;
    bo.use_markers = false;
    bo.coarse = options.coarse;  // the marker-free flags apply to the bunny too
    bo.coarse_icp_normal_spread_deg = options.coarse_icp_normal_spread_deg;
    bo.marker_free_icp = options.marker_free_icp;
    util::Timer free_timer;
    const registration::RegistrationResult bfree = registration::RegisterViews(bv, bo);
    const double free_s = free_timer.ElapsedSeconds();
    std::vector<Rigid3d> starts = bref;
    for (size_t v = 1; v < bv.size(); ++v) {
      const Vector3d cw = bref[v] * Centroid(bclouds[v]);
      const double a = 2.1 * static_cast<double>(v);
      const Rigid3d t = Rigid3d::FromAxisAngle(Vector3d(std::cos(a), std::sin(a), 0.5).normalized(),
                                               5 * M_PI / 180);
      starts[v] =
          Rigid3d(t.rotation(), cw - t.RotateDirection(cw) +
                                    5 * Vector3d(std::sin(a), 0.3, std::cos(a)).normalized()) *
          bref[v];
      bv[v].initial_world_from_sensor = starts[v];
    }
    util::Timer start_timer;
    const registration::RegistrationResult bstart = registration::RegisterViews(bv, bo);
    const double start_s = start_timer.ElapsedSeconds();
    util::Timer o3d_timer;
    // Odometry: the scans' neighbours around the bunny (315-000-045-090 degrees).
    const std::vector<Rigid3d> o3d_multi =
        Open3dMultiway(bclouds, starts, {{0, 1}, {1, 2}, {0, 3}});
    const double o3d_multi_s = o3d_timer.ElapsedSeconds();
    std::vector<Rigid3d> free_poses, start_poses;
    std::vector<bool> free_placed, start_placed;
    for (size_t v = 0; v < bv.size(); ++v) {
      free_poses.push_back(bfree.views[v].world_from_sensor);
      free_placed.push_back(bfree.views[v].placed());
      start_poses.push_back(bstart.views[v].world_from_sensor);
      start_placed.push_back(bstart.views[v].placed());
    }
    const std::vector<bool> all(bv.size(), true);
    const auto [fr, ft] = MaxViewError(free_poses, bref, bclouds, free_placed);
    const auto [sr, st] = MaxViewError(start_poses, bref, bclouds, start_placed);
    const auto [mr, mt] = MaxViewError(o3d_multi, bref, bclouds, all);
    const auto [free_rms, free_n] = PooledPairRms(bclouds, free_poses);
    const auto [start_rms, start_n] = PooledPairRms(bclouds, start_poses);
    const auto [ref_rms, ref_n] = PooledPairRms(bclouds, bref);
    const auto [spose_rms, spose_n] = PooledPairRms(bclouds, starts);
    const auto [o3_rms, o3_n] = PooledPairRms(bclouds, o3d_multi);
    const bool free_all = bfree.summary.placed == static_cast<int>(bv.size());
    j.update({{"bunny_views", bv.size()},
              {"bunny_free_placed", bfree.summary.placed},
              {"bunny_max_rot_err_deg", fr},
              {"bunny_max_trans_err_mm", ft},
              {"bunny_free_pair_rms_mm", free_all ? free_rms : NAN},
              {"bunny_free_pair_residuals", free_all ? free_n : 0},
              {"bunny_free_s", free_s},
              {"bunny_start_placed", bstart.summary.placed},
              {"bunny_start_max_rot_err_deg", sr},
              {"bunny_start_max_trans_err_mm", st},
              {"bunny_start_pair_rms_mm", start_rms},
              {"bunny_start_pair_residuals", start_n},
              {"bunny_reference_pair_rms_mm", ref_rms},
              {"bunny_reference_pair_residuals", ref_n},
              {"bunny_start_pose_pair_rms_mm", spose_rms},
              {"bunny_start_pose_pair_residuals", spose_n},
              {"open3d_multiway_bunny_max_rot_err_deg", mr},
              {"open3d_multiway_bunny_max_trans_err_mm", mt},
              {"open3d_multiway_bunny_pair_rms_mm", o3_rms},
              {"open3d_multiway_bunny_pair_residuals", o3_n},
              {"ours_multiway_s", start_s},
              {"open3d_multiway_s", o3d_multi_s}});
    for (const auto& v : bfree.views) j["bunny_free_messages"].push_back(v.message);
  }

  if (json) {
    std::cout << j.dump() << "\n";
  } else {
    std::printf("%-28s %s\n", "figure", "value");
    for (const auto& [k, v] : j.items()) std::printf("%-28s %s\n", k.c_str(), v.dump().c_str());
  }
  return 0;
}

}  // namespace
}  // namespace fringe

int main(int argc, char** argv) {
  try {
    return fringe::Run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << e.what() << "\n";
    return 1;
  }
}
