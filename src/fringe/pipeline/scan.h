// The whole scanner behind `fringe scan PROJECT --out OUT` (thesis capability 6): a scan folder
// (docs/scan-folder.md) in, a measured model and a report out.
//
// Stages, in order:
//   1. calibration: a rig given in the options (rig JSON, or OpenCV intrinsics + extrinsics),
//      else PROJECT/rig.json, else calibrated from PROJECT/calibration/ board images;
//   2. views: every PROJECT/views/NNN/{left,right}/ stack is read, decoded, matched and
//      triangulated (stereo::ViewReconstructor), its sticky markers measured
//      (registration::DetectViewMarkers), written as OUT/views/NNN.ply and
//      OUT/views/NNN.markers.json (sensor frame); views run in
//      parallel, at most `views_in_flight` at a time so that peak memory stays bounded (the
//      images of a view are dropped as soon as its cloud exists);
//   3. registration (registration::RegisterViews: markers, global marker adjustment, multi-view
//      ICP, marker-free fallback): OUT/poses.json, OUT/markers.json (the marker map) and
//      OUT/registered/NNN.ply (organized, world frame);
//   4. fusion (fusion::FuseViews, or fusion::FuseTiled in spatial tiles streamed from
//      OUT/views/ when the views do not fit in memory_limit_gib at once) into OUT/fused.ply and
//      screened Poisson meshing (fusion::MeshPoisson) into OUT/mesh.ply and OUT/mesh.stl;
//   2b. drift: every view is checked against the rig (pipeline/drift.h: the markers' epipolar
//      residual, the calibrated projector, two-direction phase), each verdict in the summary
//      with the evidence it rests on, a warning when a view drifted;
//   5. when the scan folder has truth (a simulated scan): pose errors, single-view and fused
//      RMS deviation from the truth mesh, a deviation colour map;
//   6. OUT/summary.json with every figure and OUT/report.html (pipeline/report.h).
//
// OUT is written atomically: everything goes to a temporary folder beside OUT that is renamed
// at the end, so a failure leaves no partial result; an existing OUT is replaced only when
// fringe wrote it (util::WriteFolderAtomically).
//
// Failures: bad input (missing or corrupt image, unreadable calibration, bad options) throws
// fringe::Error naming the view, the file and the stage. A view that fails (its images, its
// reconstruction, its registration) either fails the whole scan (the error lists the views that
// worked) or, with keep_going, is left out: the scan completes with the other views, the
// summary's status is kPartial and the report names the view and why.
//
// Thread safety: RunScan may run concurrently on different folders. Results do not depend on
// the number of threads (each stage is deterministic; views are collected in name order).
#pragma once

#include <cstdint>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "fringe/calib/projector_folder.h"
#include "fringe/eval/deviation.h"
#include "fringe/fusion/fuse.h"
#include "fringe/fusion/mesh.h"
#include "fringe/geometry/stereo_rig.h"
#include "fringe/pipeline/calibration_files.h"
#include "fringe/pipeline/drift.h"
#include "fringe/pipeline/refine.h"
#include "fringe/registration/markers.h"
#include "fringe/registration/register_views.h"
#include "fringe/stereo/projector_columns.h"
#include "fringe/stereo/reconstruct_view.h"

namespace fringe::pipeline {

// The calibration fields (calib, opencv, opencv_intrinsics + opencv_extrinsics, opencv_keys;
// pipeline/calibration_files.h) are inherited so that every command's options hold them under
// one name and one lookup reads them: the rig to use instead of PROJECT/rig.json or
// PROJECT/calibration/. Empty: not given.
struct ScanOptions : CalibrationFiles {
  // Leave out views that fail and finish with the others (status kPartial) instead of failing.
  bool keep_going = false;
  // Resume an interrupted run (`fringe scan --resume`): take over the temporary output folder
  // that a killed run of the same OUT left (its process no longer exists) and reuse every view
  // it finished whose inputs are unchanged: the view folder's files (names, sizes, modification
  // times), the rig and schemes as used, and resume_key. Other views and all later stages are
  // computed again; the result is the one an uninterrupted run gives.
  bool resume = false;
  // The caller's options as text (the CLI: its arguments; Python: its keyword arguments), part
  // of each view checkpoint's key: a run with other options never reuses a view.
  std::string resume_key;
  // Camera + projector scans calibrated here from calibration/KKK/ pose folders.
  calib::ProjectorFolderOptions projector_calibration;
  // Views reconstructed at the same time, [1, 64]: each holds its two image stacks (24 images
  // of 1.3 Mpx: ~60 MB for 8-bit) while it is decoded; 2 keeps both cores of a 2-core machine busy.
  int views_in_flight = 2;
  stereo::ReconstructionOptions reconstruction;
  // Memory the scan may use, GiB, >= 0; 0: half the machine's physical memory
  // (pipeline/memory_budget.h). It lowers views_in_flight to the views that fit at once, and
  // when fusing every registered view at once would exceed it, fusion runs in spatial tiles
  // streamed from OUT/views/ (fusion/tiles.h) with the largest tile that fits; a limit below
  // what one view needs is an error before any work. Meshing runs once on the fused cloud (its
  // size is the part's surface, not the number of views) and is not bounded by it.
  double memory_limit_gib = 0;
  // Fusion tile edge, mm, >= 0; 0: chosen from memory_limit_gib (one tile, the whole at once,
  // when it fits); > 0: tiles of this size whatever the limit.
  double fusion_tile_mm = 0;
  // Stereo with a rig that has no calibrated projector (one calibrated from board images): after
  // the views, the projector's columns are fitted to the scan's own points and their left
  // phases (stereo/projector_columns.h) and, when the fit is accepted, the points off their
  // projector column by more than reconstruction.matching.max_projector_error_px (false matches
  // at occlusions) are dropped: the check a calibrated projector gets in the matcher. The fit's
  // max_error_px is that tolerance (the one given here is replaced). Reported in the summary's
  // "projector_columns".
  bool fit_projector_columns = true;
  stereo::ProjectorColumnFitOptions projector_columns;
  // `fringe scan --refine`: before the views, the rig is refined from the scan's own data
  // (pipeline/refine.h; stereo only) and used when the data determine it; otherwise the scan
  // goes on with the rig as given and the summary says why. Its calib / opencv paths are not
  // used (the scan's own are).
  bool refine = false;
  RefineOptions refine_options;
  // Drift detection on every view (pipeline/drift.h); false skips it (no verdict).
  bool check_drift = true;
  DriftOptions drift;
  // Sticky markers of every view (registration/markers.h), written as OUT/views/NNN.markers.json.
  bool detect_markers = true;
  registration::MarkerDetectionOptions markers;
  registration::RegistrationOptions registration;
  fusion::FusionOptions fusion;  // registration_rms_mm is set from the registration's ICP RMS
  // The mesh follows the data: Poisson's cell is 2 point spacings, or coarser where the cloud
  // would give more than MeshOptions::max_surface_cells cells (a dense real view), and every
  // vertex is then projected onto the surface of its nearest points, which restores what the
  // coarser cell smooths (fusion/mesh.h). fused.ply keeps every point.
  fusion::MeshOptions mesh;
  // Compare with the scan folder's truth/ when it has one (simulated scans).
  bool evaluate_truth = true;
  bool write_report = true;  // OUT/report.html
  // The report's deviation colours span +-tolerance_mm (an inspection's tolerance band), mm;
  // 0: +-the 95th percentile of |deviation| (io::DeviationRange). >= 0.
  double tolerance_mm = 0;

  void Check() const;
};

enum class ScanStatus {
  kOk = 0,
  kPartial,  // keep_going: some views failed and were left out (named in the summary)
};
const char* ToString(ScanStatus s);

// One view's outcome.
struct ScanViewSummary {
  std::string name;  // folder name, "000"
  bool ok = false;
  std::string failed_stage;  // "read", "reconstruct", ... when !ok
  std::string message;       // why it failed, naming the file
  int points = 0;
  int markers = 0;                    // sticky markers measured in the view
  int projector_column_rejected = 0;  // points dropped by the fitted projector columns
  double valid_fraction = 0;          // points / left pixels
  double decode_valid_left = 0, decode_valid_right = 0;  // decoded pixel fractions
  double read_s = 0, decode_s = 0, reconstruct_s = 0;    // reconstruct_s: match to normals
  double markers_s = 0;
  // Drift check of the view against the rig (ScanOptions::check_drift).
  ViewDrift drift;
  // Registration (when the view got that far).
  std::string registration_path;  // "world", "markers", "marker-free", ...
  int matched_markers = 0;
  double marker_rms_mm = 0, adjusted_rms_mm = 0, overlap_fraction = 0;
  // Against the truth (NaN without): pose error after removing the gauge, and the RMS distance
  // of the view's points placed by their TRUE pose to the truth mesh.
  double rot_err_deg = std::numeric_limits<double>::quiet_NaN();
  double trans_err_mm = std::numeric_limits<double>::quiet_NaN();
  double truth_rms_mm = std::numeric_limits<double>::quiet_NaN();
};

struct ScanSummary {
  ScanStatus status = ScanStatus::kOk;
  std::string message;
  bool stereo = true;              // two cameras; false: one camera + projector (scan.json)
  std::string calibration_source;  // "rig.json", "calibration/ (15 board pairs)", a path
  // 0 unless calibrated here; one camera: left = the camera, and the projector's.
  double calibration_rms_left_px = 0, calibration_rms_right_px = 0;
  double calibration_rms_projector_px = 0;
  // Calibrated here: the calibration's plausibility warnings (calib/diagnostics.h) and, with
  // ScanOptions::write_report, its report's path relative to OUT ("calibration/report.html").
  std::vector<std::string> calibration_warnings;
  std::string calibration_report;
  // Drift (pipeline/drift.h): true when any view drifted; the epipolar RMS pooled over the
  // views (NaN without evidence); the views with a verdict; what the verdicts rest on.
  bool calibration_drift = false;
  double epipolar_rms_px = std::numeric_limits<double>::quiet_NaN();
  int drift_views_checked = 0;
  std::vector<std::string> drift_evidence;
  DriftOptions drift_options;
  // ScanOptions::refine: the refinement's summary (RefineSummary::ToJson), null when not asked;
  // rig_refined: the scan used the refined rig.
  nlohmann::json refinement;
  bool rig_refined = false;
  std::vector<ScanViewSummary> views;
  int views_ok = 0;
  int views_resumed = 0;  // views taken from an interrupted run (ScanOptions::resume)
  // What keeping the views for --resume costs (view_checkpoint.h): the wall time of the
  // checkpoint writes summed over the views (they run beside other views' work, so this is an
  // upper bound of what they add to views_s) and the bytes written.
  double checkpoint_s = 0;
  double checkpoint_mib = 0;
  int64_t points = 0;  // sum over the views that worked
  // Stage times. read_s, decode_s, reconstruct_s and markers_s are sums over views (several views
  // run at once, so they can exceed views_s, the wall time of the view stage); the others are wall.
  // mesh_s also covers what runs beside the one-threaded Poisson: writing fused.ply and
  // registered/, and the report's residuals; report_s is the report's pictures and HTML.
  double calibrate_s = 0, read_s = 0, decode_s = 0, reconstruct_s = 0, markers_s = 0, views_s = 0;
  double register_s = 0, fuse_s = 0, mesh_s = 0, report_s = 0;
  double total_s = 0;     // wall, calibration excluded (a rig is calibrated once, not per scan)
  double evaluate_s = 0;  // truth comparison (not in total_s: a real scan has no truth)
  // Process CPU time (all threads) of the same stages: CPU / wall shows how parallel a stage ran
  // (at most the number of cores), and CPU stays comparable on a machine shared with other jobs.
  // views_cpu_s covers read, decode, reconstruct and markers of all views together.
  double calibrate_cpu_s = 0, views_cpu_s = 0, register_cpu_s = 0, fuse_cpu_s = 0, mesh_cpu_s = 0;
  double report_cpu_s = 0, total_cpu_s = 0, evaluate_cpu_s = 0;
  double peak_mem_gib = 0;      // the process' peak resident memory (VmHWM, as getrusage's maxrss)
  double memory_limit_gib = 0;  // the limit used (ScanOptions::memory_limit_gib resolved)
  int views_in_flight = 0;      // views reconstructed at once, as the limit allowed
  // Fusion in tiles (fusion/tiles.h): the tiles fused (1: the whole at once) and their edge
  // (infinity with one tile); tiling: fusion::TiledFusionSummary::ToJson, null with one tile.
  int fusion_tiles = 1;
  double fusion_tile_mm = std::numeric_limits<double>::infinity();
  nlohmann::json tiling;
  // The projector columns fitted to the scan (ScanOptions::fit_projector_columns): whether they
  // were fitted and used, why not, their fit and the points dropped (all views); null when not
  // attempted (the rig has a projector, one camera, or the option is off).
  nlohmann::json projector_columns;
  bool projector_columns_used = false;
  int64_t projector_column_rejected = 0;
  // Registration.
  std::string registration_status;
  double marker_adjusted_rms_mm = 0;  // marker sightings after the global adjustment
  double icp_rms_mm = 0;              // point-to-plane RMS after the last ICP level
  nlohmann::json registration;        // registration::ToJson of the result
  // Fusion and mesh.
  int64_t fused_points = 0, overlap_points = 0, clusters = 0;
  int64_t mesh_vertices = 0, mesh_triangles = 0;
  bool mesh_watertight = false;
  nlohmann::json fusion, meshing;  // their summaries
  // Against the truth (has_truth; NaN otherwise). Pose errors with the
  // gauge G (one rigid transform minimising, over all views, the squared displacement of each
  // view's points between G * estimated world_from_sensor and the true pose) removed, rotation
  // error = angle of R_true^T R_est, translation error = displacement of the view's centroid;
  // max over views. As bench_fusion defines and measures them: single_view_rms_mm:
  // the views' points that lie in the overlap regions fusion merged, placed as fusion got them
  // (estimated pose mapped by G), RMS signed distance to the truth mesh; fused_rms_mm: ALL fused
  // points mapped by G (registration and fusion included). single_view_sensor_rms_mm: the same
  // overlap points placed by their TRUE pose (the sensor alone, registration excluded).
  // fused_overlap_rms_mm: only the fused points merged from >= 2 views (the like-for-like
  // partner of single_view_rms_mm); single_view_all_rms_mm: every view point, true poses;
  // mesh_rms_mm: the mesh vertices mapped by G; mesh_truth_rms_mm: the other direction, the truth
  // surface where the scan measured it (the closest truth points of the fused points) to the mesh
  // (holes and smoothed-away detail show here). truth_from_world: G (identity without truth).
  bool has_truth = false;
  Rigid3d truth_from_world;
  double pose_rot_err_deg = std::numeric_limits<double>::quiet_NaN();
  double pose_trans_err_mm = std::numeric_limits<double>::quiet_NaN();
  double single_view_all_rms_mm = std::numeric_limits<double>::quiet_NaN();
  double fused_rms_mm = std::numeric_limits<double>::quiet_NaN();
  double single_view_rms_mm = std::numeric_limits<double>::quiet_NaN();
  double single_view_sensor_rms_mm = std::numeric_limits<double>::quiet_NaN();
  double fused_overlap_rms_mm = std::numeric_limits<double>::quiet_NaN();
  double mesh_rms_mm = std::numeric_limits<double>::quiet_NaN();
  double mesh_truth_rms_mm = std::numeric_limits<double>::quiet_NaN();

  bool partial() const { return status == ScanStatus::kPartial; }
  std::string BriefReport() const;
};
// The flat figures (counts, stage times, memory, registration and truth figures; truth ones
// null without truth): what fringe demo --json and bench_pipeline --json print.
nlohmann::json FiguresJson(const ScanSummary& s);
// FiguresJson plus status, message, the per-view results and the stages' summaries
// (summary.json).
nlohmann::json ToJson(const ScanSummary& s);

// A mesh against the truth both ways, everything in the truth's frame: the RMS signed distance of
// the mesh's vertices to the truth mesh, and of the truth surface where it was measured (the
// closest truth points of `measured`, those within 2 mm of it) to the mesh. Distances beyond
// 2 mm are left out (eval::DeviationOptions). What ScanSummary's mesh_rms_mm and
// mesh_truth_rms_mm are; bench_pipeline measures other meshes of the same scan with it.
struct MeshTruthFigures {
  double vertices_rms_mm = std::numeric_limits<double>::quiet_NaN();
  double truth_rms_mm = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> vertex_deviation_mm;  // per vertex, signed (NaN: beyond 2 mm)
};
MeshTruthFigures CompareMeshWithTruth(const TriangleMesh& mesh_in_truth,
                                      const std::vector<Eigen::Vector3d>& measured_in_truth,
                                      const MeshIndex& truth);

// Runs the scan of `project` into `out`. Throws fringe::Error for bad input or options, an
// unwritable or foreign `out`, or (without keep_going) any failed view; `out` is then left as
// it was.
ScanSummary RunScan(const std::filesystem::path& project, const std::filesystem::path& out,
                    const ScanOptions& options = {});

}  // namespace fringe::pipeline
