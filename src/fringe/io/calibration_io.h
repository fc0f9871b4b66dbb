// Calibration files: the rig JSON of docs/formats.md, and import of OpenCV stereo calibration
// YAML (M1 D1 M2 D2 in intrinsics, R T in extrinsics, as written by stereo_calib samples).
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "fringe/geometry/calibration_target.h"
#include "fringe/geometry/camera.h"
#include "fringe/geometry/rigid3.h"
#include "fringe/geometry/stereo_rig.h"
#include "fringe/io/json.h"
#include "fringe/util/error.h"

namespace fringe::io {

// Checks shared by every calibration reader (rig JSON, OpenCV import): a finite camera whose
// focal length, principal point and distortion are within physical bounds, and a proper
// rotation (R R^T = I, det R = +1). Throw fringe::Error("<context>: ...").
void CheckPlausibleCamera(const CameraModel& camera, const std::string& context);
void CheckRotationMatrix(const Eigen::Matrix3d& rotation, const std::string& context);

nlohmann::json CameraToJson(const CameraModel& camera);
// `context` names where the object came from ("rig.json: cameras.left") for error messages.
CameraModel CameraFromJson(const nlohmann::json& j, const std::string& context);

// {"rotation": [[r00,r01,r02],[..],[..]], "translation_mm": [tx,ty,tz]}
nlohmann::json RigidToJson(const Rigid3d& t);
Rigid3d RigidFromJson(const nlohmann::json& j, const std::string& context);

nlohmann::json RigToJson(const StereoRig& rig);
// Reads a two-camera rig ({"cameras": {"left", "right", "projector"?}, ...}) or a single-camera
// file ({"camera": {...}}, written by `fringe calibrate` for one camera). A single camera, or
// "cameras" without "right", is returned as `left` with `right` a copy of it at zero baseline.
StereoRig RigFromJson(const nlohmann::json& j, const std::string& context);

// Whole-file helpers; ReadRig also accepts a single-camera file ({"camera": {...}}) and throws
// for anything else, naming the file and field.
StereoRig ReadRig(const std::filesystem::path& path);
void WriteRig(const std::filesystem::path& path, const StereoRig& rig,
              const nlohmann::json& extra = nlohmann::json::object());

// Calibration target description (docs/formats.md, "Calibration target"):
// {"format": "fringe-target", "type": "rings", "rows": 7, "cols": 9, "spacing_mm": 24, ...}.
// Missing fields take CalibrationTarget's defaults; the result is Check()ed.
nlohmann::json TargetToJson(const CalibrationTarget& target);
CalibrationTarget TargetFromJson(const nlohmann::json& j, const std::string& context);
CalibrationTarget ReadTarget(const std::filesystem::path& path);

// OpenCV stereo calibration split over two files as stereo_calib writes it (M1 D1 M2 D2 in the
// intrinsics, R T in the extrinsics; any spelling io/opencv_calibration.h accepts). Image size
// from the files or, when they do not store it, width x height.
StereoRig ImportOpenCvStereo(const std::filesystem::path& intrinsics,
                             const std::filesystem::path& extrinsics, int width, int height);

}  // namespace fringe::io
