// bench_camera_projector: VDI/VDE 2634-2 figures in camera-projector mode (issue 14) on the
// simulator's reference rig (../shared/SPEC.md): the LEFT camera against the projector
// (stereo/camera_projector.h), sigma 1.5 DN, heterodyne-4x3 with gamma 2.2 pre-compensated, and
// the same figures in stereo mode beside them, on the same rendered views.
//
//   Artefacts and positions as bench_reconstruction (sphere d = 30 mm in 10 positions, ball bar
//   200 mm in 7, plate in 6 across the measuring volume; bench/vdi_positions.h, shared with it,
//   so the two benchmarks measure the same views).
//   Projector calibration (calib/projector.h): 15 simulated board poses (the reference rings
//   board), each as a plain image and under heterodyne-4x3 fringes of both directions
//   (sim/projector_board.h, linear projector), decoded, features mapped into the projector by
//   local homographies, joint calibration of camera + projector; errors against the true
//   projector: proj_focal_err_pct, proj_principal_err_px, proj_rot_err_deg, proj_trans_err_mm.
//   Camera-projector figures (cp_PS_mm, ...) with that ESTIMATED calibration, and with the TRUE
//   rig (cp_*_true_calib_mm).
//   Floors cp_PF_floor / cp_F_floor: the same figures from TRUE correspondences in
//   camera-projector mode: every pixel that gave a point, its true projector column (simulator
//   truth at the pixel centre) plus Gaussian noise of the decoder's phase-noise limit
//   (phase::AbsolutePhaseSigmaPx at the pixel's modulation), triangulated with the same
//   function. cp_*_over_floor = max over positions of figure / floor (targets <= 1.3).
//   Trinocular use (stereo + the left pixels the right camera cannot see, from the left camera +
//   projector; stereo/camera_projector.h) on the demo part, 6 orbit views (the demo's), true rig:
//   demo_stereo_coverage / demo_trinocular_coverage = points on left pixels the simulator marks
//   lit and visible / those pixels; trinocular_coverage_gain = (trinocular points - stereo
//   points) / stereo points; trinocular_added_rms_mm = the added points against the true
//   surface point of their pixel.
//
// Usage: bench_camera_projector [--json] [--quick]   (--quick: 3 spheres, 2 bars, 2 plates)
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "fringe/calib/projector.h"
#include "fringe/eval/vdi2634.h"
#include "fringe/phase/decode.h"
#include "fringe/sim/board.h"
#include "fringe/sim/demo_part.h"
#include "fringe/sim/poses.h"
#include "fringe/sim/projector_board.h"
#include "fringe/sim/renderer.h"
#include "fringe/sim/scene.h"
#include "fringe/stereo/camera_projector.h"
#include "fringe/stereo/reconstruct_view.h"
#include "fringe/util/random.h"
#include "fringe/util/timer.h"
#include "vdi_positions.h"

namespace fringe {
namespace {

using bench::kBarDistanceMm;
using bench::kBarRadiusMm;
using bench::kSphereRadiusMm;

struct Bench {
  StereoRig rig = StereoRig::Reference();
  stereo::CameraProjectorRig cp = stereo::CameraProjectorRig::FromLeftCamera(rig);
  phase::PatternScheme scheme = phase::MakeScheme("heterodyne-4x3");
  sim::RenderOptions render;
  std::vector<cv::Mat> patterns = phase::GeneratePatterns(scheme, render.projector.gamma);
  double sigma_dn = std::sqrt(std::pow(render.sensor.read_noise_dn, 2) + 1.0 / 12);
  stereo::ReconstructionOptions options = [this] {
    stereo::ReconstructionOptions o;
    o.decode.noise_sigma_dn = sigma_dn;
    return o;
  }();
  stereo::ViewReconstructor cp_recon =
      stereo::MakeCameraProjectorReconstructor(cp, {scheme}, options);
  stereo::ViewReconstructor stereo_recon{rig, scheme, options};
  double cp_s = 0, stereo_s = 0;
  int views = 0;

  std::optional<stereo::ViewReconstructor> cp_est_recon;

  struct Reconstructions {
    sim::ViewImages view;
    stereo::ViewReconstruction cp, stereo, cp_est;
  };
  Reconstructions Run(const sim::Scene& scene, const Rigid3d& pose, uint64_t index) {
    Reconstructions r;
    r.view = sim::Renderer(scene, rig, render).RenderView(pose, patterns, index);
    util::Timer t;
    r.cp = cp_recon.Reconstruct(r.view.left.images, {});
    cp_s += t.ElapsedSeconds();
    t.Restart();
    r.stereo = stereo_recon.Reconstruct(r.view.left.images, r.view.right.images);
    stereo_s += t.ElapsedSeconds();
    if (cp_est_recon) r.cp_est = cp_est_recon->Reconstruct(r.view.left.images, {});
    ++views;
    return r;
  }

  // The floor points: true correspondences + phase noise, over the cloud's points that `select`
  // keeps (true point in the camera frame).
  template <typename Select>
  std::vector<Eigen::Vector3d> Floor(const Reconstructions& r, Select select, uint64_t seed) const {
    std::vector<Eigen::Vector3d> out;
    util::Rng rng(seed);
    std::normal_distribution<double> gauss(0, 1);
    const sim::CameraTruth& t = r.view.left.truth;
    const OrganizedPointCloud& cloud = r.cp.cloud;
    for (int row = 0; row < cloud.height; ++row) {
      for (int c = 0; c < cloud.width; ++c) {
        const size_t i = cloud.index(c, row);
        if (!cloud.valid[i] || !t.valid.at<uint8_t>(row, c)) continue;
        const cv::Vec3d tp = t.points.at<cv::Vec3d>(row, c);
        if (!select(Eigen::Vector3d(tp[0], tp[1], tp[2]))) continue;
        const double sigma_u =
            phase::AbsolutePhaseSigmaPx(scheme, sigma_dn, cloud.cloud.quality[i], true);
        const double u = t.projector.at<cv::Vec2d>(row, c)[0] + sigma_u * gauss(rng);
        const auto p = stereo::TriangulateCameraProjector(cp, Eigen::Vector2d(c, row), u,
                                                          phase::FringeDirection::kVertical);
        if (p.ok()) out.push_back(p.p_in_left);
      }
    }
    return out;
  }
};

double MaxAbs(double a, double b) { return std::max(std::abs(a), std::abs(b)); }

// Projector calibration from simulated boards under fringes of both directions; errors against
// the true projector into *j; the estimated camera + projector rig when it succeeded.
std::optional<StereoRig> CalibrateProjector(const StereoRig& rig, int poses, nlohmann::json* j) {
  util::Timer timer;
  const CameraModel& proj = *rig.projector;
  const CalibrationTarget target = CalibrationTarget::Reference();
  const auto schemes = sim::BothDirectionSchemes(proj);
  sim::BoardPoseOptions po;
  po.count = poses;
  po.both_cameras = false;
  std::vector<calib::TargetDetection> camera;
  std::vector<calib::ProjectorCoordinates> coordinates;
  for (const Rigid3d& pose : sim::GenerateBoardPoses(rig, target, po)) {
    const uint64_t i = camera.size();
    camera.push_back(
        calib::DetectTarget(sim::RenderBoardImage(rig.left, target, pose, {}, i).image, target));
    const auto d = sim::DecodeBoardUnderBothDirections(rig.left, proj, rig.projector_from_left,
                                                       target, pose, schemes, {}, i);
    coordinates.push_back({d[0].absolute_phase, d[1].absolute_phase, d[0].mask, d[1].mask});
  }
  const calib::ProjectorCalibration cal = calib::CalibrateCameraProjector(
      camera, coordinates, target, rig.left.width, rig.left.height, proj.width, proj.height);
  (*j)["projector_calibration"] = cal.BriefReport();
  (*j)["proj_time_s"] = timer.ElapsedSeconds();
  if (!cal.ok()) return std::nullopt;
  const CameraModel& p = *cal.rig.projector;
  const auto diff = Difference(cal.rig.projector_from_left, rig.projector_from_left);
  (*j)["proj_poses"] = cal.joint.num_pairs;
  (*j)["proj_rms_px"] = cal.projector_rms_px;
  (*j)["proj_camera_rms_px"] = cal.camera_rms_px;
  (*j)["proj_focal_err_pct"] =
      100 * std::max(std::abs(p.fx - proj.fx) / proj.fx, std::abs(p.fy - proj.fy) / proj.fy);
  (*j)["proj_principal_err_px"] = std::hypot(p.cx - proj.cx, p.cy - proj.cy);
  (*j)["proj_rot_err_deg"] = diff.angle_rad * 180 / M_PI;
  (*j)["proj_trans_err_mm"] = diff.translation_mm;
  (*j)["proj_std_dev"] = {{"fx_px", cal.joint.right.std_dev[0]},
                          {"fy_px", cal.joint.right.std_dev[1]},
                          {"cx_px", cal.joint.right.std_dev[2]},
                          {"cy_px", cal.joint.right.std_dev[3]},
                          {"rotation_rad",
                           {cal.joint.extrinsic_std_dev[0], cal.joint.extrinsic_std_dev[1],
                            cal.joint.extrinsic_std_dev[2]}},
                          {"translation_mm",
                           {cal.joint.extrinsic_std_dev[3], cal.joint.extrinsic_std_dev[4],
                            cal.joint.extrinsic_std_dev[5]}}};
  return cal.rig;
}

// Trinocular coverage on the demo part (header); writes the demo_* / trinocular_* keys.
void TrinocularCoverage(const Bench& b, int views, nlohmann::json* j) {
  util::Timer timer;
  const sim::Scene scene = sim::MakeDemoPart();
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e9), hi = -lo;
  for (const sim::SceneObject& o : scene.objects()) {
    if (o.name == "base_plate") continue;
    Eigen::Vector3d a, c;
    o.mesh.Bounds(&a, &c);
    lo = lo.cwiseMin(a);
    hi = hi.cwiseMax(c);
  }
  sim::OrbitOptions oo;
  oo.views = views;
  const std::vector<Rigid3d> poses = sim::OrbitPoses(b.rig, 0.5 * (lo + hi), oo);
  const stereo::ViewReconstructor trinocular(
      stereo::MakeTrinocularCorrespondence(b.rig, b.options.matching), {b.scheme}, b.options);
  const sim::Renderer renderer(scene, b.rig, b.render);
  long lit = 0, stereo_covered = 0, tri_covered = 0, stereo_points = 0, tri_points = 0, added = 0;
  double added_ss = 0;
  for (size_t v = 0; v < poses.size(); ++v) {
    const sim::ViewImages view = renderer.RenderView(poses[v], b.patterns, 500 + v);
    const stereo::ViewReconstruction st =
        b.stereo_recon.Reconstruct(view.left.images, view.right.images);
    const stereo::ViewReconstruction tri =
        trinocular.Reconstruct(view.left.images, view.right.images);
    const sim::CameraTruth& t = view.left.truth;
    stereo_points += st.summary.points;
    tri_points += tri.summary.points;
    for (int r = 0; r < t.valid.rows; ++r) {
      for (int c = 0; c < t.valid.cols; ++c) {
        const size_t i = st.cloud.index(c, r);
        if (t.valid.at<uint8_t>(r, c)) {
          ++lit;
          stereo_covered += st.cloud.valid[i];
          tri_covered += tri.cloud.valid[i];
        }
        if (tri.cloud.valid[i] && !st.cloud.valid[i] && t.valid.at<uint8_t>(r, c)) {
          const cv::Vec3d p = t.points.at<cv::Vec3d>(r, c);
          added_ss += (tri.cloud.cloud.points[i] - Eigen::Vector3d(p[0], p[1], p[2])).squaredNorm();
          ++added;
        }
      }
    }
  }
  (*j)["demo_views"] = views;
  (*j)["demo_stereo_coverage"] = lit ? static_cast<double>(stereo_covered) / lit : 0.0;
  (*j)["demo_trinocular_coverage"] = lit ? static_cast<double>(tri_covered) / lit : 0.0;
  (*j)["demo_stereo_points"] = stereo_points;
  (*j)["demo_trinocular_points"] = tri_points;
  (*j)["trinocular_coverage_gain"] =
      stereo_points ? static_cast<double>(tri_points - stereo_points) / stereo_points : 0.0;
  (*j)["trinocular_added_rms_mm"] = added ? std::sqrt(added_ss / added) : 0.0;
  (*j)["trinocular_time_s"] = timer.ElapsedSeconds();
}

}  // namespace
}  // namespace fringe

int main(int argc, char** argv) {
  using namespace fringe;
  bool json_out = false, quick = false;
  CLI::App app("bench_camera_projector: VDI/VDE 2634-2 figures in camera-projector mode");
  app.add_flag("--json", json_out, "Print one JSON object");
  app.add_flag("--quick", quick, "Fewer positions");
  CLI11_PARSE(app, argc, argv);
  util::Timer total;
  Bench b;
  const eval::VdiOptions vdi;
  nlohmann::json j;
  j["rig"] =
      "reference: left camera 1280x1024 + projector 1280x800 (camera-projector), "
      "both cameras (stereo); gamma 2.2 pre-compensated";
  j["scheme"] = b.scheme.name;
  j["noise_sigma_dn"] = b.render.sensor.read_noise_dn;
  j["camera_projector_baseline_mm"] = b.cp.projector_from_camera.Inverse().translation().norm();
  j["stereo_baseline_mm"] = b.rig.BaselineMm();
  const std::optional<StereoRig> est = CalibrateProjector(b.rig, quick ? 6 : 15, &j);
  if (est) {
    b.cp_est_recon.emplace(stereo::MakeCameraProjectorReconstructor(
        stereo::CameraProjectorRig::FromLeftCamera(*est), {b.scheme}, b.options));
  }

  // ---- Spheres (positions of bench_reconstruction) ----
  const sim::Scene sphere_scene = sim::MakeSphereScene(kSphereRadiusMm);
  const int n_sphere = quick ? 3 : 10;
  double cp_ps = 0, cp_pf = 0, cp_pf_floor = 0, cp_pf_ratio = 0, st_ps = 0, st_pf = 0;
  // With the estimated calibration (e_): the same maxima, ratio to the same floor.
  double e_ps = 0, e_pf = 0, e_pf_ratio = 0;
  nlohmann::json spheres = nlohmann::json::array();
  for (int k = 0; k < n_sphere; ++k) {
    const Eigen::Vector3d centre = bench::SphereCentre();
    const Rigid3d pose = bench::SpherePose(b.rig, k, n_sphere);
    const auto r = b.Run(sphere_scene, pose, 100 + k);
    const Eigen::Vector3d c_in_sensor = pose.Inverse() * centre;
    const eval::SphereResult s =
        eval::EvaluateSphere(r.cp.cloud.Compact(), 2 * kSphereRadiusMm, vdi);
    const eval::SphereResult f = eval::SphereFigures(
        b.Floor(
            r,
            [&](const Eigen::Vector3d& p) {
              return std::abs((p - c_in_sensor).norm() - kSphereRadiusMm) < 1e-3;
            },
            util::MixSeed(7, k)),
        2 * kSphereRadiusMm);
    const eval::SphereResult st =
        eval::EvaluateSphere(r.stereo.cloud.Compact(), 2 * kSphereRadiusMm, vdi);
    spheres.push_back({{"position", k},
                       {"distance_mm", c_in_sensor.norm()},
                       {"cp_points", r.cp.summary.points},
                       {"cp_status", eval::ToString(s.status)},
                       {"cp_PS_mm", s.PS_mm},
                       {"cp_PF_mm", s.PF_mm},
                       {"cp_PF_floor_mm", f.PF_mm},
                       {"stereo_points", r.stereo.summary.points},
                       {"stereo_PS_mm", st.PS_mm},
                       {"stereo_PF_mm", st.PF_mm}});
    if (s.ok()) {
      cp_ps = MaxAbs(cp_ps, s.PS_mm);
      cp_pf = std::max(cp_pf, s.PF_mm);
      if (f.ok()) {
        cp_pf_floor = std::max(cp_pf_floor, f.PF_mm);
        cp_pf_ratio = std::max(cp_pf_ratio, s.PF_mm / f.PF_mm);
      }
    }
    if (st.ok()) {
      st_ps = MaxAbs(st_ps, st.PS_mm);
      st_pf = std::max(st_pf, st.PF_mm);
    }
    if (b.cp_est_recon) {
      const eval::SphereResult e =
          eval::EvaluateSphere(r.cp_est.cloud.Compact(), 2 * kSphereRadiusMm, vdi);
      spheres.back()["cp_PS_est_calib_mm"] = e.PS_mm;
      spheres.back()["cp_PF_est_calib_mm"] = e.PF_mm;
      if (e.ok()) {
        e_ps = MaxAbs(e_ps, e.PS_mm);
        e_pf = std::max(e_pf, e.PF_mm);
        if (f.ok()) e_pf_ratio = std::max(e_pf_ratio, e.PF_mm / f.PF_mm);
      }
    }
  }

  // ---- Ball bar ----
  const sim::Scene bar_scene = sim::MakeBallBarScene(kBarRadiusMm, kBarDistanceMm);
  const int n_bar = quick ? 2 : 7;
  double cp_sd = 0, st_sd = 0, e_sd = 0;
  nlohmann::json bars = nlohmann::json::array();
  for (int k = 0; k < n_bar; ++k) {
    const Rigid3d pose = bench::BallBarPose(b.rig, k, n_bar);
    const auto r = b.Run(bar_scene, pose, 200 + k);
    const eval::BallBarResult s =
        eval::EvaluateBallBar(r.cp.cloud.Compact(), 2 * kBarRadiusMm, kBarDistanceMm, vdi);
    const eval::BallBarResult st =
        eval::EvaluateBallBar(r.stereo.cloud.Compact(), 2 * kBarRadiusMm, kBarDistanceMm, vdi);
    bars.push_back({{"position", k},
                    {"cp_status", eval::ToString(s.status)},
                    {"cp_SD_mm", s.SD_mm},
                    {"stereo_SD_mm", st.SD_mm}});
    if (s.ok()) cp_sd = MaxAbs(cp_sd, s.SD_mm);
    if (st.ok()) st_sd = MaxAbs(st_sd, st.SD_mm);
    if (b.cp_est_recon) {
      const eval::BallBarResult e =
          eval::EvaluateBallBar(r.cp_est.cloud.Compact(), 2 * kBarRadiusMm, kBarDistanceMm, vdi);
      bars.back()["cp_SD_est_calib_mm"] = e.SD_mm;
      if (e.ok()) e_sd = MaxAbs(e_sd, e.SD_mm);
    }
  }

  // ---- Plate ----
  const sim::Scene plate_scene = sim::MakePlateScene();
  const int n_plate = quick ? 2 : 6;
  double cp_f = 0, cp_f_floor = 0, cp_f_ratio = 0, st_f = 0, e_f = 0, e_f_ratio = 0;
  nlohmann::json plates = nlohmann::json::array();
  for (int k = 0; k < n_plate; ++k) {
    const Rigid3d pose = bench::PlatePose(b.rig, k, n_plate);
    const auto r = b.Run(plate_scene, pose, 300 + k);
    const eval::PlaneResult s = eval::EvaluatePlane(r.cp.cloud.Compact(), vdi);
    const eval::PlaneResult f = eval::PlaneFigures(b.Floor(
        r, [&](const Eigen::Vector3d& q) { return std::abs((pose * q).z()) < 1e-6; },
        util::MixSeed(11, k)));
    const eval::PlaneResult st = eval::EvaluatePlane(r.stereo.cloud.Compact(), vdi);
    plates.push_back({{"position", k},
                      {"cp_status", eval::ToString(s.status)},
                      {"cp_F_mm", s.F_mm},
                      {"cp_F_floor_mm", f.F_mm},
                      {"stereo_F_mm", st.F_mm}});
    if (s.ok()) {
      cp_f = std::max(cp_f, s.F_mm);
      if (f.ok()) {
        cp_f_floor = std::max(cp_f_floor, f.F_mm);
        cp_f_ratio = std::max(cp_f_ratio, s.F_mm / f.F_mm);
      }
    }
    if (st.ok()) st_f = std::max(st_f, st.F_mm);
    if (b.cp_est_recon) {
      const eval::PlaneResult e = eval::EvaluatePlane(r.cp_est.cloud.Compact(), vdi);
      plates.back()["cp_F_est_calib_mm"] = e.F_mm;
      if (e.ok()) {
        e_f = std::max(e_f, e.F_mm);
        if (f.ok()) e_f_ratio = std::max(e_f_ratio, e.F_mm / f.F_mm);
      }
    }
  }

  j["spheres"] = spheres;
  j["ball_bars"] = bars;
  j["plates"] = plates;
  // The figures with the estimated calibration; the true rig's beside them.
  const bool e = b.cp_est_recon.has_value();
  j["cp_PS_mm"] = e ? e_ps : cp_ps;
  j["cp_SD_mm"] = e ? e_sd : cp_sd;
  j["cp_PF_mm"] = e ? e_pf : cp_pf;
  j["cp_F_mm"] = e ? e_f : cp_f;
  j["cp_PF_over_floor"] = e ? e_pf_ratio : cp_pf_ratio;
  j["cp_F_over_floor"] = e ? e_f_ratio : cp_f_ratio;
  j["cp_PS_true_calib_mm"] = cp_ps;
  j["cp_SD_true_calib_mm"] = cp_sd;
  j["cp_PF_true_calib_mm"] = cp_pf;
  j["cp_F_true_calib_mm"] = cp_f;
  j["cp_PF_over_floor_true_calib"] = cp_pf_ratio;
  j["cp_F_over_floor_true_calib"] = cp_f_ratio;
  j["cp_PF_floor_mm"] = cp_pf_floor;
  j["cp_F_floor_mm"] = cp_f_floor;
  j["stereo_PS_mm"] = st_ps;
  j["stereo_SD_mm"] = st_sd;
  j["stereo_PF_mm"] = st_pf;
  j["stereo_F_mm"] = st_f;
  j["figures"] = e ? "max |.| (PS, SD) or max (PF, F) over positions; cp_* with the estimated "
                     "calibration, cp_*_true_calib with the true rig, stereo_* true rig"
                   : "projector calibration failed: every figure with the true rig";
  TrinocularCoverage(b, quick ? 2 : 6, &j);
  j["cp_time_per_view_s"] = b.views ? b.cp_s / b.views : 0.0;
  j["stereo_time_per_view_s"] = b.views ? b.stereo_s / b.views : 0.0;
  j["total_s"] = total.ElapsedSeconds();
  if (json_out) {
    std::cout << j.dump() << "\n";
    return 0;
  }
  std::printf("bench_camera_projector (reference rig, %s, sigma %.1f DN)\n", b.scheme.name.c_str(),
              b.render.sensor.read_noise_dn);
  std::printf("%-20s %12s %12s %12s %12s %10s\n", "figure", "cp est.", "cp true", "cp floor",
              "stereo", "target");
  auto row = [&](const char* name, double est, double tru, double floor, double st,
                 const char* target) {
    std::printf("%-20s %12.4f %12.4f %12.4f %12.4f %10s\n", name, e ? est : std::nan(""), tru,
                floor, st, target);
  };
  row("PS max |.| (mm)", e_ps, cp_ps, std::nan(""), st_ps, "0.02");
  row("SD max |.| (mm)", e_sd, cp_sd, std::nan(""), st_sd, "0.02");
  row("PF max (mm)", e_pf, cp_pf, cp_pf_floor, st_pf, "1.3 floor");
  row("F max (mm)", e_f, cp_f, cp_f_floor, st_f, "1.3 floor");
  std::printf("%s\n", j["projector_calibration"].get<std::string>().c_str());
  if (j.contains("proj_focal_err_pct")) {
    std::printf(
        "projector vs truth: focal %.4f %%, principal point %.3f px, rotation %.4f deg, "
        "translation %.4f mm\n",
        j["proj_focal_err_pct"].get<double>(), j["proj_principal_err_px"].get<double>(),
        j["proj_rot_err_deg"].get<double>(), j["proj_trans_err_mm"].get<double>());
  }
  std::printf(
      "PF / floor max %.2f, F / floor max %.2f (true rig); time per view: camera-projector %.3f s, "
      "stereo %.3f s\n",
      cp_pf_ratio, cp_f_ratio, j["cp_time_per_view_s"].get<double>(),
      j["stereo_time_per_view_s"].get<double>());
  std::printf(
      "trinocular on the demo part (%d views): coverage of the lit left pixels %.4f (stereo) -> "
      "%.4f, points +%.2f %%, added points RMS %.4f mm\n",
      j["demo_views"].get<int>(), j["demo_stereo_coverage"].get<double>(),
      j["demo_trinocular_coverage"].get<double>(),
      100 * j["trinocular_coverage_gain"].get<double>(),
      j["trinocular_added_rms_mm"].get<double>());
  return 0;
}
