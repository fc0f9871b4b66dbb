// The end-to-end demonstration behind `fringe demo`: a simulated measurement with the reference
// rig, evaluated against the simulator's exact truth, the way a metrologist would accept a new
// scanner:
//   1. simulate a scan of the built-in demo part (one view) with calibration-board images, and a
//      scan of the VDI/VDE 2634-2 artefacts (sphere, ball bar, plate);
//   2. calibrate the rig from the simulated board images (the TRUE rig is never used to measure);
//   3. reconstruct each view (decode, absolute-phase matching, triangulation, normals);
//   4. evaluate: deviation of the demo part from the truth mesh and its coverage; PF, PS of the
//      sphere, SD of the ball bar, F of the plate; calibration errors against the true rig.
// Every step is a library call that the CLI also exposes (simulate, calibrate, reconstruct,
// evaluate), so the output folder can be re-run step by step.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

namespace fringe::pipeline {

struct DemoOptions {
  uint64_t seed = 1;                      // scene markers, poses, board poses and noise
  int calibration_images = 15;            // board poses for calibration, >= 6
  std::string scheme = "heterodyne-4x3";  // pattern scheme preset
  // Projector gamma the patterns are pre-compensated for (the simulated projector has 2.2, as
  // real DLP projectors roughly do); 1 leaves the fringes distorted.
  double precompensate_gamma = 2.2;
  // Measure with the true rig instead of the estimated calibration (shows what calibration
  // costs); the default uses the calibration estimated from the board images.
  bool use_true_calibration = false;

  void Check() const;
};

struct DemoSummary {
  // Calibration (estimated against true rig).
  double calibration_rms_left_px = 0, calibration_rms_right_px = 0;
  double focal_error_pct = 0;  // worst |f_est - f_true| / f_true over fx, fy of both cameras
  double baseline_error_mm = 0;
  // Demo part, view 000.
  int part_points = 0;
  double part_coverage = 0;  // measured / truth-valid left pixels on part and plate
  double part_mean_mm = 0, part_rms_mm = 0, part_p95_mm = 0, part_max_mm = 0;
  // VDI/VDE 2634-2 artefacts.
  bool sphere_ok = false, ballbar_ok = false, plane_ok = false;
  double PF_mm = 0, PS_mm = 0, SD_mm = 0, F_mm = 0;
  double seconds_simulate = 0, seconds_calibrate = 0, seconds_reconstruct = 0, seconds_evaluate = 0;

  std::string Report() const;  // readable table
  nlohmann::json ToJson() const;
};

// Runs the demonstration and writes everything into out_dir atomically (report.json,
// report.txt, calibration.json, the clouds as PLY, the deviation picture, and the two scan
// folders). Throws fringe::Error when a step fails (e.g. calibration finds too few boards).
DemoSummary RunDemo(const DemoOptions& options, const std::filesystem::path& out_dir);

}  // namespace fringe::pipeline
