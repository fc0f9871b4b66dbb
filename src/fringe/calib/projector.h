// Projector calibration: the projector as an inverse camera.
//
// Input per board pose: the camera's detection of the board (detect.h, from the plain board
// image) and the decoded projector coordinates of the camera pixels under fringes in BOTH
// directions (absolute phase of vertical fringes = projector column u, of horizontal fringes =
// projector row v, phase/decode.h).
//
// Features in the projector (D. Moreno and G. Taubin, "Simple, accurate, and robust
// projector-camera calibration", 3DIMPVT 2012): around each camera feature, the camera pixels of
// a window with both coordinates valid give (camera px -> projector px) pairs; a homography
// fitted to them by linear least squares (cv::findHomography, all points) maps the feature's
// camera centre into the projector. The board is a plane, so camera -> projector is a
// homography up to the two lenses' distortion, which is smooth over a small window.
//
// Calibration: the projector's features are a TargetDetection in projector pixels; the
// camera and the projector are calibrated as a stereo pair (calibrate.h CalibrateStereo: Zhang
// per device, then one joint Ceres refinement of both intrinsics, the board poses and
// projector_from_camera with the parameter blocks of bundle.h). Projector features have no
// edges, so they are not re-measured between rounds.
//
// Frames: the camera is the reference (`left`); projector_from_camera = the stereo solution's
// right_from_left. Thread safety: reentrant.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "fringe/calib/calibrate.h"
#include "fringe/calib/detect.h"
#include "fringe/geometry/calibration_target.h"
#include "fringe/geometry/stereo_rig.h"

namespace fringe::calib {

// Decoded projector coordinates of one board pose on the camera grid.
struct ProjectorCoordinates {
  cv::Mat u, v;            // CV_32F projector column (vertical fringes) and row (horizontal)
  cv::Mat u_mask, v_mask;  // CV_8U, non-zero where valid
};

struct ProjectorFeatureOptions {
  int window_radius_px = 20;  // half-size of the camera window around a feature, [2, 200]
  int min_points = 30;        // valid pixels the window needs, >= 8
  void Check() const;
};

// The camera features of one view mapped into the projector (features whose window has too few
// valid pixels are left out). status kOk with the mapped features, kNotFound when the camera
// detection failed or fewer than 4 features map.
TargetDetection MapFeaturesToProjector(const TargetDetection& camera,
                                       const ProjectorCoordinates& coordinates, int projector_width,
                                       int projector_height,
                                       const ProjectorFeatureOptions& options = {});

struct ProjectorCalibration {
  // left = the camera, projector + projector_from_left; right = copy of the camera at zero
  // baseline (a camera-projector rig, io/calibration_io.h writes it without `right`).
  StereoRig rig;
  StereoCalibration joint;  // left = camera, right = projector (std devs, per-view residuals)
  std::vector<TargetDetection> projector_views;  // the mapped features per view
  double projector_rms_px = 0;  // reprojection RMS of the projector's features, joint solution
  double camera_rms_px = 0;
  bool ok() const { return joint.summary.ok(); }
  std::string BriefReport() const;
};

// camera_views[i] and coordinates[i]: one board pose. Throws fringe::Error for mismatched sizes.
ProjectorCalibration CalibrateCameraProjector(const std::vector<TargetDetection>& camera_views,
                                              const std::vector<ProjectorCoordinates>& coordinates,
                                              const CalibrationTarget& target, int camera_width,
                                              int camera_height, int projector_width,
                                              int projector_height,
                                              const CalibrationOptions& options = {},
                                              const ProjectorFeatureOptions& feature_options = {},
                                              const std::vector<std::string>& names = {});

// Two cameras + projector (a stereo sensor with a calibrated projector, the trinocular use of
// stereo/camera_projector.h). Per pose each camera detects the board and decodes both fringe
// directions; each camera's features are mapped into the projector (MapFeaturesToProjector), and
// both mappings are observations of the projector (two independent measurements of the same
// projector feature). Joint refinement of the three devices (CalibrateDevices: the left camera
// as reference, right_from_left and projector_from_left, every intrinsics and board pose).
struct CamerasProjectorCalibration {
  StereoRig rig;                 // left, right, right_from_left, projector, projector_from_left
  MultiDeviceCalibration joint;  // devices: 0 left, 1 right, 2 projector
  std::vector<TargetDetection> projector_views;  // both cameras' mapped features per pose
  bool ok() const { return joint.ok(); }
  std::string BriefReport() const;
};

// left/right[i], left/right_coordinates[i]: one board pose. Throws fringe::Error for
// mismatched counts.
CamerasProjectorCalibration CalibrateCamerasProjector(
    const std::vector<TargetDetection>& left, const std::vector<TargetDetection>& right,
    const std::vector<ProjectorCoordinates>& left_coordinates,
    const std::vector<ProjectorCoordinates>& right_coordinates, const CalibrationTarget& target,
    const cv::Size& left_size, const cv::Size& right_size, const cv::Size& projector_size,
    const CalibrationOptions& options = {}, const ProjectorFeatureOptions& feature_options = {},
    const std::vector<std::string>& names = {});

}  // namespace fringe::calib
