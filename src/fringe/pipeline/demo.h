// The end-to-end demonstration behind `fringe demo`: the whole scanner on a simulated
// measurement with the reference rig, evaluated against the simulator's exact truth, the way a
// metrologist would accept a new scanner:
//   1. simulate a multi-view scan of the built-in demo part with its sticky markers (`views`
//      sensor poses around it) and calibration-board images, and a one-view scan of the
//      VDI/VDE 2634-2 artefacts (sphere, ball bar, plate);
//   2. run the scanner (pipeline::RunScan) on the demo part: calibrate from the simulated board
//      images (the TRUE rig is never used to measure), reconstruct, detect markers, register,
//      fuse, mesh, report; the truth comparison (pose errors, single-view and fused RMS) is the
//      scan's own (ScanSummary);
//   3. calibration errors against the true rig; PF, PS of the sphere, SD of the ball bar, F of
//      the plate measured with the calibrated rig.
// Every step is a library call that the CLI also exposes (simulate, scan, reconstruct,
// evaluate), so the output folder can be re-run step by step.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "fringe/pipeline/scan.h"

namespace fringe::pipeline {

struct DemoOptions {
  uint64_t seed = 1;  // scene markers, poses, board poses and noise
  int views = 8;      // sensor poses around the part, [2, 64]
  // Camera and projector resolution relative to the reference rig's 1280 x 1024, (0.25, 1]. The
  // demo's default is half size (README: the time at full size); markers (5 mm) need >= 0.5.
  double rig_scale = 0.5;
  int calibration_images = 15;  // board poses for calibration, >= 6
  // Pattern scheme preset. Its patterns are pre-compensated for the simulated projector's gamma
  // (sim::ProjectorOptions::gamma, 2.2 as real DLP projectors roughly have), as a user would do
  // for a measured projector; the scheme written with the scan says so (gamma_precompensation).
  std::string scheme = "heterodyne-4x3";
  // Measure with the true rig instead of the estimated calibration (shows what calibration
  // costs); the default uses the calibration estimated from the board images.
  bool use_true_calibration = false;
  // The scanner's options (its mesh: Poisson depth 9, ~0.8 mm cells over the ~300 mm scene,
  // 2 point spacings of the half-size rig).
  ScanOptions scan;

  void Check() const;
};

struct DemoSummary {
  int views = 0;
  double rig_scale = 1;
  int image_width = 0, image_height = 0;
  // Calibration (estimated against true rig).
  double calibration_rms_left_px = 0, calibration_rms_right_px = 0;
  double focal_error_pct = 0;  // worst |f_est - f_true| / f_true over fx, fy of both cameras
  double baseline_error_mm = 0;
  // The scan of the demo part: stage times, registration, fusion, truth figures.
  ScanSummary scan;
  // VDI/VDE 2634-2 artefacts.
  bool sphere_ok = false, ballbar_ok = false, plane_ok = false;
  double PF_mm = 0, PS_mm = 0, SD_mm = 0, F_mm = 0;
  double simulate_s = 0, vdi_s = 0, total_s = 0;  // total_s: the whole demo, wall

  std::string Report() const;  // short readable table
};
// The keys (views, points, simulate_s, calibrate_s, total_s = the scan's wall time
// without calibration, read_s, decode_s, reconstruct_s, register_s, fuse_s, mesh_s, report_s,
// peak_mem_gib, pose_rot_err_deg, pose_trans_err_mm, fused_rms_mm, single_view_rms_mm) and
// the calibration and VDI figures; demo_s = the whole demo.
nlohmann::json ToJson(const DemoSummary& s);

// Runs the demonstration and writes everything into out_dir atomically: scan-demo/ and
// scan-vdi/ (the simulated scan folders), scan/ (the scanner's output with report.html),
// vdi_artefacts.ply, report.json, report.txt. Throws fringe::Error when a step fails (e.g.
// calibration finds too few boards, a view cannot be registered).
DemoSummary RunDemo(const DemoOptions& options, const std::filesystem::path& out_dir);

}  // namespace fringe::pipeline
