// bench_reconstruction: accuracy and speed of one-view reconstruction on the simulator's
// reference rig (../shared/SPEC.md), per issue 6.
//
//   VDI/VDE 2634-2 figures on simulated artefacts in several positions of the measuring volume
//   (sphere d = 30 mm in 10 positions, ball bar 200 mm in 7, plate 220 mm in 6), with the true
//   calibration and with the calibration estimated from simulated board images (calib module);
//   noise floors PF_floor / F_floor: the same figures from the TRUE surface points of the same
//   pixels displaced along their rays by the depth noise propagated from the phase-noise limit
//   (since issue 10 the whole stack's: phase::AbsolutePhaseSigmaPx, the inverse-variance
//   combination of every set's sigma_u = P/(2 pi) sqrt(2/N) sigma_I / B per camera, with the same
//   B in every set; through the phase gradient along the epipolar line and the triangulation
//   geometry); depth_noise_ratio = RMS measured range error / RMS
//   propagated sigma (plates, true calibration).
//   Demo part: RMS signed deviation from the truth mesh and coverage (left pixels seeing the lit
//   part that give a point).
//   Normals: grid normals vs Open3D EstimateNormals (KNN 30) on the same cloud, angular error
//   against the simulator's true normals, and time.
//   Time per view: 2 x 1280x1024, 12 images each, in memory -> organized cloud with normals.
//
// Usage: bench_reconstruction [--json] [--quick] [--view-only] [--repeats N] [--finest-set-only]
// (--quick: fewer positions, no calibration; --view-only: the demo part's view alone (time,
// deviation, normals, demo_cloud_digest), no VDI artefacts; --repeats: reconstructions of the
// demo view timed, median (3); --finest-set-only: absolute phase from the finest set alone, as
// before issue 10)
//
// One Measure* function per artefact kind (and the demo part, the normals), each returning its
// figures; main collects them into one JSON object (AddFigures) and prints it or the table.
#include <tbb/global_control.h>
#include <CLI/CLI.hpp>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "bench_timing.h"
#include "fringe/calib/calibrate.h"
#include "fringe/calib/detect.h"
#include "fringe/eval/deviation.h"
#include "fringe/eval/vdi2634.h"
#include "fringe/geometry/calibration_target.h"
#include "fringe/geometry/normals.h"
#include "fringe/phase/decode.h"
#include "fringe/sim/board.h"
#include "fringe/sim/demo_part.h"
#include "fringe/sim/poses.h"
#include "fringe/sim/renderer.h"
#include "fringe/sim/scene.h"
#include "fringe/stereo/reconstruct_view.h"
#include "fringe/stereo/rectification.h"
#include "fringe/stereo/triangulation.h"
#include "fringe/util/memory.h"
#include "fringe/util/random.h"
#include "fringe/util/timer.h"
#include "vdi_positions.h"

#ifdef FRINGE_HAVE_OPEN3D
#include <open3d/geometry/KDTreeSearchParam.h>
#include <open3d/geometry/PointCloud.h>
#endif

namespace fringe {
namespace {

using bench::kBarDistanceMm;
using bench::kBarRadiusMm;
using bench::kSphereRadiusMm;

struct Context {
  StereoRig rig_true = StereoRig::Reference();
  std::optional<StereoRig> rig_est;
  phase::PatternScheme scheme = phase::MakeScheme("heterodyne-4x3");
  std::vector<cv::Mat> patterns;
  double sigma_dn = 0;      // camera noise incl. quantisation
  bool whole_stack = true;  // decoder combines every set (false: --finest-set-only)
  sim::RenderOptions render;
  nlohmann::json calib_json;
};

sim::ViewImages Render(const Context& ctx, const sim::Scene& scene, const Rigid3d& pose,
                       uint64_t view) {
  const sim::Renderer renderer(scene, ctx.rig_true, ctx.render);
  return renderer.RenderView(pose, ctx.patterns, view);
}

Eigen::Vector3d Vec(const cv::Vec3d& v) { return {v[0], v[1], v[2]}; }

// Predicted range sigma (mm, along the left ray) of a left pixel from the phase-noise limit.
double PredictedRangeSigma(const Context& ctx, const stereo::Rectification& rect, int c, int r,
                           const Eigen::Vector3d& p, const Eigen::Vector3d& n,
                           double modulation_dn) {
  const StereoRig& rig = ctx.rig_true;
  // The decoder's absolute phase: the whole stack's inverse-variance combination (issue 10),
  // or the finest set alone with --finest-set-only. The cloud keeps set 0's modulation; the
  // sets are taken to have the same modulation (no camera or projector defocus here).
  const double sigma_u =
      phase::AbsolutePhaseSigmaPx(ctx.scheme, ctx.sigma_dn, modulation_dn, ctx.whole_stack);
  // Projector column change per rectified right pixel along the epipolar line, on the local
  // tangent plane of the true surface.
  const Eigen::Vector2d rr = rect.ProjectRectified(stereo::Side::kRight, p);
  const Eigen::Vector2d right_px = rect.OriginalFromRectified(stereo::Side::kRight, rr);
  const Eigen::Vector2d right_px1 =
      rect.OriginalFromRectified(stereo::Side::kRight, rr + Eigen::Vector2d(1, 0));
  const Rigid3d left_from_right = rig.right_from_left.Inverse();
  const Eigen::Vector3d o = left_from_right.translation();
  const Eigen::Vector3d d = left_from_right.RotateDirection(rig.right.Ray(right_px1));
  const double den = n.dot(d);
  if (std::abs(den) < 1e-9) return std::nan("");
  const Eigen::Vector3d p1 = o + (n.dot(p - o) / den) * d;
  const double g = rig.projector->Project(rig.projector_from_left * p1).x() -
                   rig.projector->Project(rig.projector_from_left * p).x();
  const auto t0 = stereo::Triangulate(rig, Eigen::Vector2d(c, r), right_px);
  const auto t1 = stereo::Triangulate(rig, Eigen::Vector2d(c, r), right_px1);
  if (!t0.ok() || !t1.ok() || g == 0) return std::nan("");
  const double ds = (t1.p_in_left - t0.p_in_left).norm();
  return std::sqrt(2.0) * sigma_u / std::abs(g) * ds;
}

struct FloorPoints {
  std::vector<Eigen::Vector3d> floor;  // true points + propagated noise
  double sum_sq_measured = 0, sum_sq_predicted = 0;
  int n = 0;
};

// Over the valid cloud pixels where `select` holds: the floor points and the noise statistics.
template <typename Select>
FloorPoints NoiseFloor(const Context& ctx, const stereo::Rectification& rect,
                       const sim::ViewImages& view, const OrganizedPointCloud& cloud, Select select,
                       uint64_t seed) {
  FloorPoints f;
  util::Rng rng(seed);
  std::normal_distribution<double> gauss(0, 1);
  const sim::CameraTruth& t = view.left.truth;
  for (int r = 0; r < cloud.height; ++r) {
    for (int c = 0; c < cloud.width; ++c) {
      const size_t i = cloud.index(c, r);
      if (!cloud.valid[i] || !t.valid.at<uint8_t>(r, c)) continue;
      const Eigen::Vector3d p = Vec(t.points.at<cv::Vec3d>(r, c));
      if (!select(r, c, p)) continue;
      const Eigen::Vector3d n = Vec(t.normals.at<cv::Vec3d>(r, c));
      const double sigma = PredictedRangeSigma(ctx, rect, c, r, p, n, cloud.cloud.quality[i]);
      if (!std::isfinite(sigma)) continue;
      const Eigen::Vector3d ray = p.normalized();
      f.floor.push_back(p + sigma * gauss(rng) * ray);
      const double e = (cloud.cloud.points[i] - p).dot(ray);
      f.sum_sq_measured += e * e;
      f.sum_sq_predicted += sigma * sigma;
      ++f.n;
    }
  }
  return f;
}

// Estimated calibration from simulated board images (20 poses), as `fringe calibrate` does.
void EstimateCalibration(Context* ctx) {
  util::Timer timer;
  const CalibrationTarget target = CalibrationTarget::Reference();
  sim::BoardPoseOptions pose_options;
  pose_options.count = 20;
  const auto poses = sim::GenerateBoardPoses(ctx->rig_true, target, pose_options);
  std::vector<calib::TargetDetection> left, right;
  for (size_t i = 0; i < poses.size(); ++i) {
    const auto imgs = sim::RenderStereoBoard(ctx->rig_true, target, poses[i], {}, i);
    left.push_back(calib::DetectTarget(imgs.left.image, target));
    right.push_back(calib::DetectTarget(imgs.right.image, target));
  }
  const calib::StereoCalibration cal = calib::CalibrateStereo(
      left, right, target, ctx->rig_true.left.width, ctx->rig_true.left.height);
  ctx->calib_json = {{"success", cal.summary.ok()},
                     {"rms_px", cal.rms_px},
                     {"pairs", cal.num_pairs},
                     {"time_s", timer.ElapsedSeconds()},
                     {"baseline_error_mm", cal.rig.BaselineMm() - ctx->rig_true.BaselineMm()},
                     {"fx_left_error_px", cal.rig.left.fx - ctx->rig_true.left.fx}};
  if (cal.summary.ok()) ctx->rig_est = cal.rig;
}

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180 / M_PI;
}

// The reconstructors of one run: with the true calibration and, unless --quick, with the one
// estimated from simulated board images.
struct Reconstructors {
  const stereo::ViewReconstructor& true_calib;
  const stereo::ViewReconstructor* est_calib = nullptr;  // null: calibration not run
  const stereo::Rectification& rect;                     // of the true rig (noise floors)
};

// Sphere figures: maxima over the positions (true / estimated calibration, noise floor) and the
// per-position JSON.
struct SphereFigures {
  double ps_max = 0, pf_max = 0, pf_floor_max = 0, pf_ratio_max = 0;
  double ps_est_max = 0, pf_est_max = 0;
  nlohmann::json positions = nlohmann::json::array();
};

SphereFigures MeasureSpheres(const Context& ctx, const Reconstructors& recon, int n_sphere) {
  SphereFigures fig;
  const eval::VdiOptions vdi;
  const sim::Scene sphere_scene = sim::MakeSphereScene(kSphereRadiusMm);
  for (int k = 0; k < n_sphere; ++k) {
    const Eigen::Vector3d centre = bench::SphereCentre();
    const Rigid3d pose = bench::SpherePose(ctx.rig_true, k, n_sphere);
    const sim::ViewImages view = Render(ctx, sphere_scene, pose, 100 + k);
    const auto rec = recon.true_calib.Reconstruct(view.left.images, view.right.images);
    const eval::SphereResult s =
        eval::EvaluateSphere(rec.cloud.Compact(), 2 * kSphereRadiusMm, vdi);
    const Eigen::Vector3d c_in_sensor = pose.Inverse() * centre;
    const FloorPoints f = NoiseFloor(
        ctx, recon.rect, view, rec.cloud,
        [&](int, int, const Eigen::Vector3d& p) {
          return std::abs((p - c_in_sensor).norm() - kSphereRadiusMm) < 1e-3;
        },
        util::MixSeed(7, k));
    const eval::SphereResult fs = eval::SphereFigures(f.floor, 2 * kSphereRadiusMm);
    nlohmann::json e = {{"position", k},
                        {"distance_mm", c_in_sensor.norm()},
                        {"points", rec.summary.points},
                        {"status", eval::ToString(s.status)},
                        {"PS_mm", s.PS_mm},
                        {"PF_mm", s.PF_mm},
                        {"PF_floor_mm", fs.PF_mm}};
    if (s.ok()) {
      fig.ps_max = std::max(fig.ps_max, std::abs(s.PS_mm));
      fig.pf_max = std::max(fig.pf_max, s.PF_mm);
      fig.pf_floor_max = std::max(fig.pf_floor_max, fs.PF_mm);
      if (fs.ok() && fs.PF_mm > 0)
        fig.pf_ratio_max = std::max(fig.pf_ratio_max, s.PF_mm / fs.PF_mm);
    }
    if (recon.est_calib) {
      const auto re = recon.est_calib->Reconstruct(view.left.images, view.right.images);
      const eval::SphereResult se =
          eval::EvaluateSphere(re.cloud.Compact(), 2 * kSphereRadiusMm, vdi);
      e["PS_est_calib_mm"] = se.PS_mm;
      e["PF_est_calib_mm"] = se.PF_mm;
      if (se.ok()) {
        fig.ps_est_max = std::max(fig.ps_est_max, std::abs(se.PS_mm));
        fig.pf_est_max = std::max(fig.pf_est_max, se.PF_mm);
      }
    }
    fig.positions.push_back(e);
  }

  return fig;
}

struct BallBarFigures {
  double sd_max = 0, sd_est_max = 0;
  nlohmann::json positions = nlohmann::json::array();
};

BallBarFigures MeasureBallBars(const Context& ctx, const Reconstructors& recon, int n_bar) {
  BallBarFigures fig;
  const eval::VdiOptions vdi;
  const sim::Scene bar_scene = sim::MakeBallBarScene(kBarRadiusMm, kBarDistanceMm);
  for (int k = 0; k < n_bar; ++k) {
    const Rigid3d pose = bench::BallBarPose(ctx.rig_true, k, n_bar);
    const sim::ViewImages view = Render(ctx, bar_scene, pose, 200 + k);
    const auto rec = recon.true_calib.Reconstruct(view.left.images, view.right.images);
    const eval::BallBarResult b =
        eval::EvaluateBallBar(rec.cloud.Compact(), 2 * kBarRadiusMm, kBarDistanceMm, vdi);
    nlohmann::json e = {{"position", k}, {"status", eval::ToString(b.status)}, {"SD_mm", b.SD_mm}};
    if (b.ok()) fig.sd_max = std::max(fig.sd_max, std::abs(b.SD_mm));
    if (recon.est_calib) {
      const auto re = recon.est_calib->Reconstruct(view.left.images, view.right.images);
      const eval::BallBarResult be =
          eval::EvaluateBallBar(re.cloud.Compact(), 2 * kBarRadiusMm, kBarDistanceMm, vdi);
      e["SD_est_calib_mm"] = be.SD_mm;
      if (be.ok()) fig.sd_est_max = std::max(fig.sd_est_max, std::abs(be.SD_mm));
    }
    fig.positions.push_back(e);
  }

  return fig;
}

// Plate figures; the depth noise sums are over every plate (depth_noise_ratio).
struct PlateFigures {
  double f_max = 0, f_floor_max = 0, f_ratio_max = 0, f_est_max = 0;
  double noise_measured = 0, noise_predicted = 0;
  int64_t noise_n = 0;
  nlohmann::json positions = nlohmann::json::array();
};

PlateFigures MeasurePlates(const Context& ctx, const Reconstructors& recon, int n_plate) {
  PlateFigures fig;
  const eval::VdiOptions vdi;
  const sim::Scene plate_scene = sim::MakePlateScene();
  for (int k = 0; k < n_plate; ++k) {
    const Rigid3d pose = bench::PlatePose(ctx.rig_true, k, n_plate);
    const sim::ViewImages view = Render(ctx, plate_scene, pose, 300 + k);
    const auto rec = recon.true_calib.Reconstruct(view.left.images, view.right.images);
    const eval::PlaneResult p = eval::EvaluatePlane(rec.cloud.Compact(), vdi);
    const Rigid3d world_from_sensor = pose;
    const FloorPoints f = NoiseFloor(
        ctx, recon.rect, view, rec.cloud,
        [&](int, int, const Eigen::Vector3d& q) {
          return std::abs((world_from_sensor * q).z()) < 1e-6;
        },
        util::MixSeed(11, k));
    const eval::PlaneResult fp = eval::PlaneFigures(f.floor);
    fig.noise_measured += f.sum_sq_measured;
    fig.noise_predicted += f.sum_sq_predicted;
    fig.noise_n += f.n;
    nlohmann::json e = {{"position", k},
                        {"status", eval::ToString(p.status)},
                        {"F_mm", p.F_mm},
                        {"F_floor_mm", fp.F_mm},
                        {"depth_noise_mm", f.n ? std::sqrt(f.sum_sq_measured / f.n) : 0.0},
                        {"predicted_noise_mm", f.n ? std::sqrt(f.sum_sq_predicted / f.n) : 0.0}};
    if (p.ok()) {
      fig.f_max = std::max(fig.f_max, p.F_mm);
      fig.f_floor_max = std::max(fig.f_floor_max, fp.F_mm);
      if (fp.ok() && fp.F_mm > 0) fig.f_ratio_max = std::max(fig.f_ratio_max, p.F_mm / fp.F_mm);
    }
    if (recon.est_calib) {
      const auto re = recon.est_calib->Reconstruct(view.left.images, view.right.images);
      const eval::PlaneResult pe = eval::EvaluatePlane(re.cloud.Compact(), vdi);
      e["F_est_calib_mm"] = pe.F_mm;
      if (pe.ok()) fig.f_est_max = std::max(fig.f_est_max, pe.F_mm);
    }
    fig.positions.push_back(e);
  }

  return fig;
}

// The demo part in one position: time per view (median of --repeats), deviation from the truth
// mesh, coverage of the lit pixels, the left camera's truth (normals).
struct DemoFigures {
  stereo::ViewReconstruction rec;
  double view_time_s = 0;
  double view_cpu_s = 0;  // process CPU time (all threads) of the view, median
  eval::DeviationStats dev;
  double coverage = 0;
  sim::CameraTruth truth;
};

DemoFigures MeasureDemoPart(const Context& ctx, const stereo::ViewReconstructor& recon,
                            int repeats) {
  DemoFigures fig;
  const sim::Scene demo = sim::MakeDemoPart();
  Eigen::Vector3d bmin, bmax;
  demo.Bounds(&bmin, &bmax);
  const Eigen::Vector3d target(0.5 * (bmin.x() + bmax.x()), 0.5 * (bmin.y() + bmax.y()), 10);
  const Rigid3d demo_pose =
      sim::SensorPoseLookingAt(ctx.rig_true, target, Eigen::Vector3d(0.2, -0.5, 1).normalized());
  const sim::ViewImages demo_view = Render(ctx, demo, demo_pose, 400);
  std::vector<double> times, cpu;
  for (int rep = 0; rep < repeats; ++rep) {
    fig.rec = {};  // the previous result's memory is freed outside the timing
    util::Timer t;
    const double cpu0 = bench::CpuMs();
    fig.rec = recon.Reconstruct(demo_view.left.images, demo_view.right.images);
    times.push_back(t.ElapsedSeconds());
    cpu.push_back((bench::CpuMs() - cpu0) * 1e-3);
  }
  fig.view_cpu_s = bench::Median(cpu);
  std::sort(times.begin(), times.end());
  const PointCloud demo_cloud = fig.rec.cloud.Compact();
  TriangleMesh mesh = demo.CombinedMesh();
  mesh.Transform(demo_pose.Inverse());
  const MeshIndex mesh_distance(std::move(mesh));
  fig.dev = eval::DeviationFromMesh(demo_cloud, mesh_distance);
  int lit = 0, covered = 0;
  fig.truth = demo_view.left.truth;
  const sim::CameraTruth& dt = fig.truth;
  for (int r = 0; r < fig.rec.cloud.height; ++r) {
    for (int c = 0; c < fig.rec.cloud.width; ++c) {
      if (!dt.valid.at<uint8_t>(r, c)) continue;
      ++lit;
      covered += fig.rec.cloud.valid[fig.rec.cloud.index(c, r)];
    }
  }
  fig.view_time_s = times[times.size() / 2];
  fig.coverage = lit ? static_cast<double>(covered) / lit : 0.0;
  return fig;
}

// Normals on the demo cloud: ours (already in the reconstruction, re-timed alone) vs Open3D
// KNN 30, mean angle to the simulator's true normals.
struct NormalFigures {
  double ours_err = 0, ours_s = 0;
  double o3d_err = std::nan(""), speedup = std::nan("");
  nlohmann::json json;
};

NormalFigures CompareNormals(const OrganizedPointCloud& cloud, const sim::CameraTruth& truth,
                             const GridNormalOptions& options) {
  NormalFigures fig;
  OrganizedPointCloud grid = cloud;
  util::Timer nt;
  EstimateGridNormals(&grid, options);
  fig.ours_s = nt.ElapsedSeconds();
  std::vector<Eigen::Vector3d> true_normals;
  std::vector<size_t> grid_ids;
  for (int r = 0; r < grid.height; ++r) {
    for (int c = 0; c < grid.width; ++c) {
      const size_t i = grid.index(c, r);
      if (!grid.valid[i]) continue;
      grid_ids.push_back(i);
      true_normals.push_back(Vec(truth.normals.at<cv::Vec3d>(r, c)));
    }
  }
  int ours_n = 0;
  for (size_t k = 0; k < grid_ids.size(); ++k) {
    const Eigen::Vector3d& n = grid.cloud.normals[grid_ids[k]];
    if (!n.allFinite() || !true_normals[k].allFinite()) continue;
    fig.ours_err += AngleDeg(n, true_normals[k]);
    ++ours_n;
  }
  fig.ours_err /= std::max(ours_n, 1);
  fig.json = {{"points", grid_ids.size()},
              {"grid_mean_err_deg", fig.ours_err},
              {"grid_time_s", fig.ours_s}};
#ifdef FRINGE_HAVE_OPEN3D
  {
    open3d::geometry::PointCloud pc;
    for (size_t i : grid_ids) pc.points_.push_back(grid.cloud.points[i]);
    util::Timer ot;
    pc.EstimateNormals(open3d::geometry::KDTreeSearchParamKNN(30));
    const double est_s = ot.ElapsedSeconds();
    pc.OrientNormalsTowardsCameraLocation(Eigen::Vector3d::Zero());
    const double o3d_s = ot.ElapsedSeconds();
    double err = 0;
    int n = 0;
    for (size_t k = 0; k < pc.normals_.size(); ++k) {
      if (!true_normals[k].allFinite()) continue;
      err += AngleDeg(pc.normals_[k], true_normals[k]);
      ++n;
    }
    fig.o3d_err = err / std::max(n, 1);
    fig.speedup = est_s / fig.ours_s;
    fig.json["open3d_mean_err_deg"] = fig.o3d_err;
    fig.json["open3d_estimate_s"] = est_s;
    fig.json["open3d_estimate_and_orient_s"] = o3d_s;
  }
#endif

  return fig;
}

struct Figures {
  SphereFigures spheres;
  BallBarFigures bars;
  PlateFigures plates;
  DemoFigures demo;
  NormalFigures normals;
};

// The figures' JSON keys (docs/benchmarks.md): the headline VDI figures from the estimated
// calibration when it was run, else from the true one.
void AddFigures(const Context& ctx, const Figures& fig, nlohmann::json* j) {
  (*j)["spheres"] = fig.spheres.positions;
  (*j)["ball_bars"] = fig.bars.positions;
  (*j)["plates"] = fig.plates.positions;
  (*j)["PS_mm"] = ctx.rig_est ? fig.spheres.ps_est_max : fig.spheres.ps_max;
  (*j)["PF_mm"] = ctx.rig_est ? fig.spheres.pf_est_max : fig.spheres.pf_max;
  (*j)["SD_mm"] = ctx.rig_est ? fig.bars.sd_est_max : fig.bars.sd_max;
  (*j)["F_mm"] = ctx.rig_est ? fig.plates.f_est_max : fig.plates.f_max;
  (*j)["figures_from"] = ctx.rig_est ? "estimated calibration (max |.| over positions)"
                                     : "true calibration (calibration not run: --quick)";
  (*j)["PS_true_calib_mm"] = fig.spheres.ps_max;
  (*j)["PF_true_calib_mm"] = fig.spheres.pf_max;
  (*j)["SD_true_calib_mm"] = fig.bars.sd_max;
  (*j)["F_true_calib_mm"] = fig.plates.f_max;
  (*j)["PF_floor_mm"] = fig.spheres.pf_floor_max;
  (*j)["F_floor_mm"] = fig.plates.f_floor_max;
  (*j)["PF_over_floor_max"] = fig.spheres.pf_ratio_max;
  (*j)["F_over_floor_max"] = fig.plates.f_ratio_max;
  (*j)["plate_depth_noise_mm"] =
      fig.plates.noise_n > 0 ? std::sqrt(fig.plates.noise_measured / fig.plates.noise_n) : 0.0;
  (*j)["depth_noise_ratio"] =
      fig.plates.noise_predicted > 0
          ? std::sqrt(fig.plates.noise_measured / fig.plates.noise_predicted)
          : 0;
  (*j)["demo_rms_mm"] = fig.demo.dev.rms_mm;
  (*j)["demo_deviation"] = {{"mean_mm", fig.demo.dev.mean_mm},
                            {"p95_mm", fig.demo.dev.p95_mm},
                            {"max_mm", fig.demo.dev.max_mm},
                            {"points", fig.demo.dev.points},
                            {"unmatched", fig.demo.dev.unmatched}};
  (*j)["coverage"] = fig.demo.coverage;
  (*j)["normals_err_deg"] = fig.normals.ours_err;
  (*j)["open3d_normals_err_deg"] = fig.normals.o3d_err;
  (*j)["normals_speedup_vs_open3d"] = fig.normals.speedup;
  (*j)["normals"] = fig.normals.json;
  (*j)["view_time_s"] = fig.demo.view_time_s;
  (*j)["view_cpu_s"] = fig.demo.view_cpu_s;
  (*j)["view_breakdown_s"] = {{"decode", fig.demo.rec.summary.decode_s},
                              {"match", fig.demo.rec.summary.match_s},
                              {"outliers", fig.demo.rec.summary.outliers_s},
                              {"normals", fig.demo.rec.summary.normals_s}};
  (*j)["demo_points"] = fig.demo.rec.summary.points;
  // FNV-1a over the demo view's organized cloud (validity, then every valid point's position,
  // normal, quality, intensity and residual): two builds whose digests agree reconstructed the
  // view to identical bits.
  bench::Digest digest;
  const OrganizedPointCloud& cloud = fig.demo.rec.cloud;
  digest.Add(cloud.valid.data(), cloud.valid.size());
  for (size_t i = 0; i < cloud.valid.size(); ++i) {
    if (!cloud.valid[i]) continue;
    digest.Add(cloud.cloud.points[i].data(), sizeof(double) * 3);
    if (cloud.cloud.has_normals()) digest.Add(cloud.cloud.normals[i].data(), sizeof(double) * 3);
    if (cloud.cloud.has_quality()) digest.Add(&cloud.cloud.quality[i], sizeof(float));
    if (cloud.cloud.has_intensity()) digest.Add(&cloud.cloud.intensity[i], sizeof(float));
    if (cloud.cloud.has_residual()) digest.Add(&cloud.cloud.residual_px[i], sizeof(float));
  }
  (*j)["demo_cloud_digest"] = digest.Hex();
}

// The human-readable table, from the JSON object.
void PrintTable(const Context& ctx, const nlohmann::json& j) {
  const auto num = [&](const char* key) { return j.at(key).get<double>(); };
  const auto& breakdown = j.at("view_breakdown_s");
  std::printf("bench_reconstruction (reference rig, %s, sigma %.1f DN)\n", ctx.scheme.name.c_str(),
              ctx.render.sensor.read_noise_dn);
  std::printf("%-34s %12s %12s %12s\n", "figure", "true calib", "est. calib", "floor");
  auto row = [&](const char* name, const char* key, const char* floor_key) {
    std::printf("%-34s %12.4f %12.4f %12.4f\n", name,
                num((std::string(key) + "_true_calib_mm").c_str()),
                ctx.rig_est ? num((std::string(key) + "_mm").c_str()) : std::nan(""),
                floor_key ? num(floor_key) : std::nan(""));
  };
  row("PS max |.| (mm), 10 spheres", "PS", nullptr);
  row("PF max (mm)", "PF", "PF_floor_mm");
  row("SD max |.| (mm), 7 ball bars", "SD", nullptr);
  row("F max (mm), 6 plates", "F", "F_floor_mm");
  std::printf("PF / floor max %.2f, F / floor max %.2f, depth noise ratio %.2f\n",
              num("PF_over_floor_max"), num("F_over_floor_max"), num("depth_noise_ratio"));
  std::printf("demo part: RMS deviation %.4f mm, coverage %.3f, %d points\n", num("demo_rms_mm"),
              num("coverage"), j.at("demo_points").get<int>());
  std::printf("normals: grid %.2f deg in %.3f s; Open3D KNN30 %.2f deg; speedup %.1fx\n",
              num("normals_err_deg"), j.at("normals").at("grid_time_s").get<double>(),
              num("open3d_normals_err_deg"), num("normals_speedup_vs_open3d"));
  std::printf(
      "time per view: %.3f s, %.3f s of CPU (decode %.3f, match %.3f, outliers %.3f, normals "
      "%.3f)\n",
      num("view_time_s"), num("view_cpu_s"), breakdown.at("decode").get<double>(),
      breakdown.at("match").get<double>(), breakdown.at("outliers").get<double>(),
      breakdown.at("normals").get<double>());
  std::printf("demo cloud digest %s\n", j.at("demo_cloud_digest").get<std::string>().c_str());
  if (!ctx.calib_json.empty()) std::printf("calibration: %s\n", ctx.calib_json.dump().c_str());
}

}  // namespace
}  // namespace fringe

int main(int argc, char** argv) {
  fringe::util::UseTransparentHugePages(argv);  // as the fringe program does
  using namespace fringe;
  bool json_out = false, quick = false, finest_only = false, view_only = false;
  int repeats = 3;
  CLI::App app("bench_reconstruction: accuracy and speed of one-view reconstruction");
  app.add_flag("--json", json_out, "Print one JSON object");
  app.add_flag("--quick", quick, "Fewer positions, no calibration");
  app.add_flag("--finest-set-only", finest_only,
               "Absolute phase from the finest set alone (as before issue 10)");
  app.add_flag("--view-only", view_only,
               "Only the demo part's view (time, deviation, normals): no VDI artefacts, no "
               "calibration");
  app.add_option("--repeats", repeats, "Reconstructions of the demo view timed (median)")
      ->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);
  if (view_only) quick = true;
  Context ctx;
  ctx.whole_stack = !finest_only;
  ctx.patterns = phase::GeneratePatterns(ctx.scheme, ctx.render.projector.gamma);
  ctx.sigma_dn = std::sqrt(std::pow(ctx.render.sensor.read_noise_dn, 2) + 1.0 / 12);
  nlohmann::json j;
  j["rig"] = "reference (1280x1024 cameras, 1280x800 projector, gamma 2.2 pre-compensated)";
  j["scheme"] = ctx.scheme.name;
  j["noise_sigma_dn"] = ctx.render.sensor.read_noise_dn;
  if (!quick) EstimateCalibration(&ctx);
  j["calibration"] = ctx.calib_json;

  stereo::ReconstructionOptions options;
  options.decode.noise_sigma_dn = ctx.sigma_dn;
  options.decode.whole_stack = ctx.whole_stack;
  j["whole_stack_phase"] = ctx.whole_stack;
  const stereo::ViewReconstructor recon_true(ctx.rig_true, ctx.scheme, options);
  std::optional<stereo::ViewReconstructor> recon_est;
  if (ctx.rig_est) recon_est.emplace(*ctx.rig_est, ctx.scheme, options);
  const stereo::Rectification rect(ctx.rig_true);
  const Reconstructors recon{recon_true, recon_est ? &*recon_est : nullptr, rect};

  Figures fig;
  if (!view_only) {
    fig.spheres = MeasureSpheres(ctx, recon, quick ? 3 : 10);
    fig.bars = MeasureBallBars(ctx, recon, quick ? 2 : 7);
    fig.plates = MeasurePlates(ctx, recon, quick ? 2 : 6);
  }
  fig.demo = MeasureDemoPart(ctx, recon_true, repeats);
  fig.normals = CompareNormals(fig.demo.rec.cloud, fig.demo.truth, options.normals);
  AddFigures(ctx, fig, &j);
  if (json_out) {
    std::cout << j.dump() << "\n";
  } else {
    PrintTable(ctx, j);
  }
  return 0;
}
