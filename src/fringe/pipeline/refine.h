// `fringe refine PROJECT --out RIG` and `fringe scan --refine`: the rig refined
// from a scan's own data. Every view of the scan folder is decoded and reconstructed with the
// given rig; its points (sampled on the left grid, each with its left phase and the right
// camera's phase map) and its markers seen by both cameras (matched with a wider epipolar
// tolerance than a scan uses, so that a drifted rig still pairs them) go into one Ceres bundle
// (calib/refine_rig.h). The result is written only when the data determine it.
//
// Stereo scan folders (rig.json in the folder, or --calib / --opencv). A camera + projector scan
// folder is refused with a clear error: its projector is the triangulating device (one fringe
// direction leaves nothing redundant) and its refinement from two directions is not written.
//
// Thread safety: reentrant.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "fringe/calib/refine_rig.h"
#include "fringe/geometry/stereo_rig.h"
#include "fringe/pipeline/calibration_files.h"
#include "fringe/registration/markers.h"
#include "fringe/scan/scan_folder.h"
#include "fringe/stereo/reconstruct_view.h"

namespace fringe::pipeline {

// The rig to refine instead of PROJECT/rig.json: the calibration fields (calib, opencv, the
// OpenCV pair, opencv_keys; pipeline/calibration_files.h), read as `fringe scan` reads them.
struct RefineOptions : CalibrationFiles {
  calib::RigRefinementOptions rig;
  // An artefact file (docs/formats.md) whose sphere is in the scan: its certified diameter
  // constrains the sphere's shape (calib/refine_rig.h) and, under scale kAuto, holds the scale.
  // Empty: none. Read by RefineRigFromScan into rig.sphere (a file without a sphere is an error).
  std::filesystem::path artefact;
  // Phase points per view, sampled evenly over its measured left pixels, >= 0 (0: markers only).
  int points_per_view = 2000;
  stereo::ReconstructionOptions reconstruction;
  // Marker pairing: the scan's 2 px epipolar tolerance would drop the markers of a rig drifted
  // by more than ~0.05 degrees, exactly the ones refinement needs; the depth test against the
  // surface still picks the right pair.
  registration::MarkerDetectionOptions markers = [] {
    registration::MarkerDetectionOptions o;
    o.max_epipolar_px = 8;
    return o;
  }();
  void Check() const;
};

struct RefineSummary {
  std::string calibration_source;
  calib::RigRefinementSummary refinement;
  double gather_s = 0, solve_s = 0;
  bool ok() const { return refinement.ok(); }
  std::string BriefReport() const;
};
nlohmann::json ToJson(const RefineSummary& s);

struct RefineResult {
  StereoRig rig;  // refined when ok(), else the input rig
  RefineSummary summary;
};

// The rig of a scan folder as `fringe scan` resolves it without calibrating: the given files
// (LookUpRig), else PROJECT/rig.json; *source names it. Throws fringe::Error when there is none.
StereoRig ReadScanRig(const scan::ScanFolder& folder, const CalibrationFiles& files,
                      std::string* source);

// Adds one view's markers and sampled phase points to `data` (view index `view`): `rec` is the
// view reconstructed with `rig` (its right phase map is kept in data.right_phase[view]). What
// RefineRigFromScan does per view; benchmarks call it on views reconstructed in memory.
void AddViewToRefinement(const StereoRig& rig, int view, const stereo::ViewReconstruction& rec,
                         const RefineOptions& options, calib::RigRefinementData* data);

// Which of the data's phase points lie on the certified sphere, view by view, from the initial
// triangulation: eval's sphere search with the certified diameter (RANSAC, then a least-squares
// fit with a free radius), accepted only when the fit is that sphere (its radius within 10 % of
// the certified one: a rig bent by a few % stays well inside, another object rarely does; seen
// over a cap of at least 25 degrees; at most 10 % of the view's points inside it: a solid
// sphere hides its inside) and at least 20 points are on it. A point is on it within 3 % of the
// radius of the fitted sphere (a bent rig deforms it by about 1 % of the radius; the band scales
// with the artefact, not with the noise of one scanner). Sets RefinePhasePoint::sphere and
// appends one RefineSphereView per view it was found in; returns a line per view for the log.
std::vector<std::string> MarkSpherePoints(const calib::RefineSphere& sphere,
                                          calib::RigRefinementData* data);

// Refines `rig` from the views of `folder` (stereo). Throws fringe::Error for bad options or
// input (unreadable images, a camera + projector folder); data failures come back in the summary.
RefineResult RefineRigFromScan(const scan::ScanFolder& folder, const StereoRig& rig,
                               const RefineOptions& options = {});

// `fringe refine`: the rig resolved as above, refined, and written to `out_rig` (atomically, the
// refinement's summary inside as "refinement") when ok; otherwise nothing is written. `out_rig`
// must not be an input.
RefineResult RefineScanRig(const std::filesystem::path& project,
                           const std::filesystem::path& out_rig, const RefineOptions& options = {});

}  // namespace fringe::pipeline
