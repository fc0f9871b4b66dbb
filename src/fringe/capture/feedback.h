// The 3D part of the operator's feedback after a captured view: is the new view usable and does
// it connect to the scan so far? With a calibrated rig (CaptureOptions::rig_file, else
// PROJECT/rig.json) the new view is reconstructed (stereo::ViewReconstructor, as `fringe scan`
// does), its sticky markers measured (registration::DetectViewMarkers, or
// DetectViewMarkersOneCamera for a camera + projector folder) and — once the project has two
// views — the views are registered (registration::RegisterViews: markers, then the marker-free
// path) to say whether the new view is placed with the previous ones and how much it overlaps
// them. Nothing here is a second implementation: it is the scanner's own stages on one view.
//
// Previous views are not reconstructed again at every capture: each view's cloud and markers are
// kept in PROJECT/.capture-feedback/NNN.{ply,markers.json}, valid while the rig, the schemes and
// the options they were made with are the same (PROJECT/.capture-feedback/key.json); a view
// without a cached entry is reconstructed from its images. The cache is only an accelerator:
// `fringe scan` never reads it, and deleting it is harmless.
//
// Thread safety: one feedback per project at a time (the cache is per project).
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "fringe/geometry/stereo_rig.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/registration/markers.h"
#include "fringe/registration/register_views.h"
#include "fringe/stereo/reconstruct_view.h"

namespace fringe::capture {

struct ViewFeedbackOptions {
  stereo::ReconstructionOptions reconstruction;  // as `fringe scan` (decode, matching, outliers)
  registration::MarkerDetectionOptions markers;
  registration::RegistrationOptions registration;
  // Keep the views' clouds and markers in PROJECT/.capture-feedback/ for the next capture.
  bool cache = true;
  void Check() const;
};

// What the scanner's stages say about the newest view of a project.
struct ViewFeedback {
  std::string view;        // "003"
  std::string rig_source;  // the rig file used
  bool reconstructed = false;
  std::string message;  // why it is not reconstructed / registered (empty when it is)
  int points = 0;       // 3D points of the new view
  int markers = 0;      // sticky markers measured in the new view
  int rings_left = 0, rings_right = 0;  // rings found in each camera's texture
  // Registration, once the project has two views (previous_views >= 1).
  int previous_views = 0;  // views before the new one that were reconstructed
  bool registration_run = false;
  bool registered = false;        // the new view is placed with the previous ones
  std::string registration_path;  // registration::ToString(ViewPath): "markers", "marker-free", ...
  std::string registration_message;  // how it was placed or why not
  int matched_markers = 0;           // markers shared with the previous views' map
  double marker_rms_mm = 0;          // of its marker fit
  double overlap_fraction = 0;       // largest ICP overlap with another view, [0, 1]
  std::string registration_status;   // registration::ToString(RegistrationStatus) of all views
  double seconds = 0;
};
nlohmann::json ToJson(const ViewFeedback& f);

// Feedback for the view `view` of the scan folder `project` (its images are read from the
// folder), with the rig in `rig_file`. Previous views are those before `view` in the folder.
// Throws fringe::Error for a bad rig file or one that does not fit the folder (image size,
// projector for a one-camera folder); data failures (no points, no markers, not registered)
// come back in the result.
ViewFeedback AssessViewIn3D(const std::filesystem::path& project, const std::string& view,
                            const std::filesystem::path& rig_file,
                            const ViewFeedbackOptions& options = {});

}  // namespace fringe::capture
