// Diagnostics of a finished calibration (`fringe calibrate --report DIR`): what a user needs to
// trust it or to see why not.
//   - per board pose and per device: RMS and max reprojection residual, whether the pose was
//     used and, for a rejected one, why (calibrate.h rejects the poses whose RMS is an outlier
//     among the poses and solves again);
//   - per device: a residual vector plot and a coverage map of where the board's points fell on
//     the sensor (distortion is unconstrained where nothing fell), the covered fraction;
//   - plausibility warnings: a baseline or projector distance outside [10 mm, 5 m] (translations
//     in metres or micrometres taken for millimetres), a focal length implausible for the image
//     size (field of view) or for the pixel size when given, non-square pixels, coverage below
//     half the sensor, too few poses, no pose tilted against the camera (focal length and
//     distortion are then not separable);
//   - the predicted depth uncertainty of the calibrated pair over its working volume (the box
//     spanned by the calibration's board points in the left camera frame): the rig parameters'
//     joint covariance (calibrate.h StereoCalibration::rig_covariance) propagated to the depth
//     of a point triangulated from a fixed pixel pair (first order, numerical derivatives), at
//     the volume's centre and its eight corners, and as a map over the left image at the
//     centre's depth. It is the calibration's share of the measurement uncertainty (the phase
//     noise of a scan comes on top).
//
// Frames: the left (reference) camera frame, mm. Thread safety: reentrant.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "fringe/calib/calibrate.h"
#include "fringe/calib/calibrate_folder.h"
#include "fringe/calib/projector_folder.h"
#include "fringe/geometry/calibration_target.h"
#include "fringe/io/report.h"
#include "fringe/util/files.h"

namespace fringe::calib {

struct DiagnosticsOptions {
  // Plausible distance of a second device (camera or projector) from the first, mm,
  // 0 < min < max.
  double min_distance_mm = 10;
  double max_distance_mm = 5000;
  // Plausible horizontal field of view, degrees, 0 < min < max < 180.
  double min_fov_deg = 2;
  double max_fov_deg = 150;
  // Sensor pixel size, micrometres, >= 0 (0: unknown); when given, the focal length in mm must
  // lie in [min_focal_mm, max_focal_mm] (0 < min < max).
  double pixel_size_um = 0;
  double min_focal_mm = 1;
  double max_focal_mm = 500;
  // fx / fy further from 1 than this is warned about (non-square pixels are rare; a poorly
  // constrained focal length is not), > 0.
  double max_aspect_deviation = 0.05;
  // Covered fraction of each sensor below which a warning is given, [0, 1].
  double min_coverage = 0.5;
  // Coverage map resolution: cells along the longer image side, [8, 512].
  int coverage_cells = 64;
  // Fewest used poses without a warning, >= 1.
  int min_poses = 6;
  // The most tilted used pose must be tilted by at least this much against the reference
  // camera's optical axis, degrees, [0, 90).
  double min_tilt_deg = 10;
  // Predicted depth map: samples along the longer side of the left image, [4, 256].
  int prediction_cells = 32;
  void Check() const;
};

struct PoseDiagnostics {
  std::string name;
  bool used = false;
  std::string message;         // why it was not used (rejection reason), "" when used
  std::vector<double> rms_px;  // per device (0 where the device did not see it)
  std::vector<double> max_px;  // per device
  std::vector<int> features;   // per device
  double tilt_deg = 0;         // board normal against the reference camera's axis (used poses)
};

struct DeviceDiagnostics {
  std::string name;
  int width = 0, height = 0;
  double rms_px = 0, max_px = 0;  // over the used poses' features
  double coverage = 0;            // fraction of the sensor inside some used pose's board hull
  cv::Mat coverage_map;           // CV_32F, used poses covering each cell (coverage_cells)
  double fx = 0, fy = 0;
  double fov_deg = 0;   // horizontal field of view
  double focal_mm = 0;  // fx x pixel size (0: pixel size unknown)
};

struct DepthSigma {
  std::string where;  // "centre", "corner 1" .. "corner 8"
  Eigen::Vector3d point_in_left = Eigen::Vector3d::Zero();
  double sigma_mm = 0;
};

struct CalibrationDiagnostics {
  std::vector<DeviceDiagnostics> devices;
  std::vector<PoseDiagnostics> poses;
  std::vector<std::string> rejections;     // "pose NAME: reason", one per rejected pose
  std::vector<std::string> warnings;       // plausibility warnings, readable
  std::vector<std::string> warning_codes;  // one per warning: "distance", "focal", "aspect",
                                           // "coverage", "few_poses", "no_tilt"
  // Distances of the further devices from the first, mm, with their names.
  std::vector<std::pair<std::string, double>> distances_mm;
  double max_tilt_deg = 0;
  int used_poses = 0;
  // Predicted depth uncertainty: centre first, then the eight corners; empty when the
  // calibration has no pair or no covariance (then prediction_message says why).
  std::vector<DepthSigma> predicted_depth_sigma_mm;
  std::string prediction_message;
  cv::Mat predicted_sigma_map;  // CV_32F over the left image at the centre's depth, NaN outside
  bool has_warning(const std::string& code) const;
  std::string BriefReport() const;
};

// A device of the calibration: its name ("camera", "left", "right", "projector") and its
// joint-solution result (calibrate.h: per-view residuals, camera_from_board).
struct DiagnosedDevice {
  std::string name;
  const CameraCalibration* calibration = nullptr;
};

// `devices[0]` is the reference camera (its camera_from_board places the poses); `pose_names`
// name the views (index = view). `distances_mm`: the further devices' distances from the first
// (name, mm). `pair` (may be null): the stereo or camera + projector calibration whose
// rig_covariance gives the predicted depth uncertainty. Throws fringe::Error for bad options or
// a device without a calibration.
CalibrationDiagnostics DiagnoseCalibration(
    const std::vector<DiagnosedDevice>& devices, const std::vector<std::string>& pose_names,
    const CalibrationTarget& target,
    const std::vector<std::pair<std::string, double>>& distances_mm, const StereoCalibration* pair,
    const DiagnosticsOptions& options = {});

// The predicted depth sigma (mm) of a point in the left frame from the pair's rig covariance
// (first-order propagation through the midpoint triangulation of its two pixels); NaN when the
// point projects behind a device or the covariance is missing.
double PredictedDepthSigmaMm(const StereoRig& rig, const Eigen::MatrixXd& rig_covariance,
                             const Eigen::Vector3d& point_in_left);

// summary.json's "diagnostics" object.
nlohmann::json ToJson(const CalibrationDiagnostics& d);
// The calibration report (calibration/report.html): verdict and warnings, rejected poses, the
// table of poses, per device the residual vectors and the coverage map, the predicted depth
// uncertainty with its map.
io::Report CalibrationReport(const CalibrationDiagnostics& d,
                             const std::vector<DiagnosedDevice>& devices);

// The diagnostics of what `fringe calibrate` produced, with the devices they describe (which
// point into the calibration: it must outlive this).
struct CalibrationDiagnosis {
  CalibrationDiagnostics diagnostics;
  std::vector<DiagnosedDevice> devices;
  CalibrationTarget target;  // the board, for the report's 3D view of the poses
};
// One camera ("camera") or a stereo pair ("left", "right"; baseline, predicted depth sigma).
CalibrationDiagnosis DiagnoseFolderCalibration(const FolderCalibration& cal,
                                               const CalibrationTarget& target,
                                               const DiagnosticsOptions& options = {});
// Camera + projector ("camera", "projector"; projector distance, predicted depth sigma of the
// camera-projector pair triangulated from both projector coordinates) or two cameras +
// projector ("left", "right", "projector"; both distances; no depth prediction yet: the joint
// solve of three devices does not keep its covariance).
CalibrationDiagnosis DiagnoseProjectorCalibration(const ProjectorFolderCalibration& cal,
                                                  const CalibrationTarget& target,
                                                  const DiagnosticsOptions& options = {});
// Writes the folder `dir` atomically: summary.json ({"calibration": calibration_json,
// "diagnostics": ToJson(...)}) and report.html (CalibrationReport, with the 3D view of the
// boards and devices, calibration_scene.h, after its summary).
void WriteCalibrationReport(const std::filesystem::path& dir, const CalibrationDiagnosis& d,
                            const nlohmann::json& calibration_json,
                            const util::OutputFolderOptions& output = {});

}  // namespace fringe::calib
