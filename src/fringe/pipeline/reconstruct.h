// `fringe reconstruct VIEW --out CLOUD`: one view folder (left/ and right/ fringe image stacks,
// or one camera's stacks with a calibrated projector) to an organized point cloud in the left
// camera frame, its reprojection residuals and its sticky markers, as a library call (the CLI
// parses flags for it, the Python module binds it).
//
// What it finds by itself, in this order (docs/scan-folder.md): the image folders (left/ and
// right/, or L/ and R/ as other tools write them; left/vertical/ and left/horizontal/ for both
// fringe directions), the scheme (the scan folder's when VIEW is ROOT/views/NNN, else a
// manifest beside the images), the calibration (the files given, else VIEW/rig.json or
// VIEW/../rig.json), and the bit depth (the scan folder's). Every output is checked before any
// work (never an input, distinct from each other) and written together or not at all.
//
// Thread safety: reentrant (the reconstruction uses TBB inside).
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fringe/phase/scheme_presets.h"
#include "fringe/pipeline/calibration_files.h"
#include "fringe/registration/markers.h"
#include "fringe/stereo/reconstruct_view.h"

namespace fringe::pipeline {

enum class ReconstructMode {
  // Stereo when the view has right/ images and the rig a right camera, else camera-projector.
  kAuto = 0,
  kStereo,           // two cameras
  kCameraProjector,  // the left camera against the rig's projector (columns, or both directions)
  // Stereo, plus the left pixels the right camera cannot see from the left camera + projector.
  kTrinocular,
};
const char* ToString(ReconstructMode m);  // "auto", "stereo", "camera-projector", "trinocular"
// Throws fringe::Error naming the accepted names for anything else.
ReconstructMode ReconstructModeFromString(const std::string& name);

// The calibration (CalibrationFiles: empty = the rig JSON beside the view) and how to decode.
struct ReconstructFolderOptions : CalibrationFiles {
  ReconstructMode mode = ReconstructMode::kAuto;
  // Scheme manifest or preset name; empty: the scan folder's, else a manifest beside the view.
  std::string scheme;
  phase::SchemeParameters parameters;  // for a preset name
  // Significant bits of the images (1-16); 0: the scan folder's scan.json, else the
  // container's. Sets reconstruction.decode.full_scale_dn.
  int bit_depth = 0;
  stereo::ReconstructionOptions reconstruction;
  bool detect_markers = true;  // OUT.markers.json beside the cloud
  bool ascii_ply = false;
  // Also the per-pixel reprojection residual (32-bit float TIFF); empty: none.
  std::filesystem::path residuals;
  void Check() const;
};

struct ViewFolderReconstruction {
  stereo::ViewReconstruction reconstruction;      // summary.ok() (else ReconstructViewFolder threw)
  ReconstructMode mode = ReconstructMode::kAuto;  // resolved: never kAuto
  bool two_directions = false;                    // left/vertical/ + left/horizontal/
  std::string rig_source;                         // the calibration file(s) used
  std::filesystem::path view, cloud, residuals;   // residuals empty when not written
  std::optional<registration::ViewMarkers> markers;
  std::filesystem::path markers_file;  // empty without markers
  // The stages' brief reports in order (decoding per camera, matching, outliers, normals,
  // the view), as `fringe reconstruct` prints them.
  std::vector<std::string> report;
};
// {view, mode, out, summary, markers: {file, count, report}}: what `reconstruct --json` prints.
nlohmann::json ToJson(const ViewFolderReconstruction& r);

// Reconstructs `view` into `cloud` (a .ply name). Throws fringe::Error naming the file and the
// problem: missing image folders, scheme or calibration, a scheme or rig that does not fit the
// images, an output that is an input or is not .ply, a reconstruction with no points (naming
// the calibration, the usual cause). Nothing is written unless every output is.
ViewFolderReconstruction ReconstructViewFolder(const std::filesystem::path& view,
                                               const std::filesystem::path& cloud,
                                               const ReconstructFolderOptions& options = {});

}  // namespace fringe::pipeline
