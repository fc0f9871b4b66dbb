// Projector calibration of a folder of board poses, as run by `fringe calibrate DIR --target T
// --out RIG` when DIR holds fringe stacks (layout in docs/scan-folder.md):
//   one camera:   DIR/KKK/{board image, vertical/, horizontal/}
//   two cameras:  DIR/KKK/left/{board image, vertical/, horizontal/} and DIR/KKK/right/{...}
// vertical/ and horizontal/ hold the camera's fringe images of a scheme with that direction and
// its manifest.json (phase::ReadScheme). Per pose and camera: the board is detected in the plain
// image (detect.h), both stacks are decoded (phase/decode.h), and the board features are mapped
// into the projector (projector.h); then camera(s) and projector are calibrated jointly.
//
// Every size read (images, manifests) is checked against the other poses before the work;
// errors name the file. Thread safety: reentrant.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "fringe/calib/projector.h"
#include "fringe/phase/decode.h"

namespace fringe::calib {

struct ProjectorFolderOptions {
  CalibrationOptions calibration;    // both devices (k3, tangential, rounds, rejection)
  ProjectorFeatureOptions features;  // the local homographies' windows
  DetectionOptions detection;        // the board in the plain images
  phase::DecodeOptions decode;       // the fringe stacks
  void Check() const;
};

enum class ProjectorFolderLayout {
  kNone,              // no pose folder with fringe stacks
  kCameraProjector,   // DIR/KKK/{board, vertical/, horizontal/}
  kCamerasProjector,  // DIR/KKK/{left,right}/{board, vertical/, horizontal/}
};

// The layout of DIR and its pose folders (sorted by name). Throws fringe::Error when DIR is not
// a folder or mixes both layouts.
ProjectorFolderLayout FindProjectorPoseFolders(const std::filesystem::path& dir,
                                               std::vector<std::filesystem::path>* poses);

struct ProjectorFolderCalibration {
  ProjectorFolderLayout layout = ProjectorFolderLayout::kNone;
  std::vector<std::string> names;  // pose folder names
  // The board detections of each camera per pose (right empty for one camera): what
  // `fringe calibrate --centres` writes.
  std::vector<TargetDetection> left_detections, right_detections;
  // The calibrated rig: camera + projector (no right camera: `right` a copy of the left at
  // zero baseline, as a camera + projector rig file reads), or both cameras + projector.
  StereoRig rig;
  ProjectorCalibration camera_projector;  // kCameraProjector
  CamerasProjectorCalibration cameras;    // kCamerasProjector
  bool ok() const {
    return layout == ProjectorFolderLayout::kCamerasProjector ? cameras.ok()
                                                              : camera_projector.ok();
  }
  std::string message() const;  // why it failed ("" when ok)
  std::string BriefReport() const;
  // The left camera's joint-solution calibration (residual image).
  const CameraCalibration& LeftCamera() const;
};
// The "calibration" object of the rig file: RMS per device, poses, standard deviations of
// every device's intrinsics and of the extrinsics (rotation vector rad, translation mm).
nlohmann::json CalibrationToJson(const ProjectorFolderCalibration& s);

// Throws fringe::Error for a folder without the layout, unreadable or mis-sized images, a
// manifest of the wrong direction or projector size (naming the file). A calibration that does
// not converge comes back with ok() false and message().
ProjectorFolderCalibration CalibrateProjectorFolder(const std::filesystem::path& dir,
                                                    const CalibrationTarget& target,
                                                    const ProjectorFolderOptions& options = {});

}  // namespace fringe::calib
