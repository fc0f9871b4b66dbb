// Camera and stereo calibration from detected board views (detect.h).
//
// Method: Z. Zhang, "A flexible new technique for camera calibration" (PAMI 2000). The start
// comes from OpenCV's cv::calibrateCamera on the raw detected centres (its plane-homography
// initialisation and refinement: robust under heavy distortion); then Ceres Solver
// (Levenberg-Marquardt, automatic derivatives of the camera model of geometry/camera.h, the
// parameter blocks of bundle.h: one intrinsics block per device, one pose per board view, one
// device_from_reference pose per further device) refines fx fy cx cy k1 k2 p1 p2 [k3] and all
// poses on OUR centres, re-measured between rounds as below, minimising the reprojection error,
// optionally under a robust loss. The final solve must converge (Ceres' CONVERGENCE), else the
// calibration is a reported failure carrying Ceres' termination type and message.
//
// Circular features are re-measured between refinement rounds with the current model: their
// subpixel edge points are undistorted to ideal pinhole pixels, the ellipses refitted there (an
// exact conic only after undistortion), and the centre taken as the ellipse centre minus its
// perspective bias predicted from the estimated board pose (bias = centre of the projected
// circle's conic minus the projection of its centre), then distorted back. Rings start from
// their pose-free pole-polar centre (detect.h); once the pose is known, the bias-corrected
// centres of both ring edges (inverse-variance weighted) replace it, provided they agree with
// the pole-polar centre. This removes the ellipse-centre bias (~0.05-0.4 px) and the
// distortion-induced one.
//
// Robustness: views whose RMS exceeds max(max_image_rms_px, 3 x median) (the median over the
// views: a robust statistic that one bad pose does not move) are rejected with a message naming
// the limit and the problem solved again (unless reject_outlier_views is false); single features
// beyond outlier_sigma x RMS are dropped. Standard deviations: sqrt(diag(sigma^2 (J^T J)^-1)) at
// the optimum from ceres::Covariance, sigma^2 = SSE / (m - n) (bundle.h, StandardDeviations).
//
// Stereo: both cameras calibrated alone, right_from_left initialised from the per-view relative
// poses, then one joint refinement of both intrinsics, left_from_board per view and
// right_from_left. Epipolar errors: distance of each right feature from the epipolar line of its
// left partner (undistorted, right camera pixels).
//
// Frames: camera_from_board per view; right_from_left as in stereo_rig.h; millimetres (the
// target's unit). Thread safety: reentrant.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "fringe/calib/bundle.h"
#include "fringe/calib/detect.h"
#include "fringe/geometry/calibration_target.h"
#include "fringe/geometry/camera.h"
#include "fringe/geometry/rigid3.h"
#include "fringe/geometry/stereo_rig.h"

namespace fringe::calib {

struct CalibrationOptions {
  bool estimate_k3 = false;         // estimate k3 (else fixed at 0)
  bool estimate_tangential = true;  // estimate p1 p2 (else fixed at 0)
  int max_iterations = 200;         // Ceres iterations per solve, >= 1
  int centre_rounds = 3;            // re-measurements of circular centres with the model, [0, 10]
  double max_image_rms_px = 1.0;    // views above max(this, 3 x median RMS) are rejected, > 0
  // Reject the views whose RMS is an outlier among the views (above) and solve again; false
  // keeps every usable view (`fringe calibrate --keep-all`).
  bool reject_outlier_views = true;
  double outlier_sigma = 6.0;           // drop features beyond this many RMS (and > 1 px), > 0
  int min_features = 6;                 // fewer features in a view: the view is not used, >= 4
  int min_views = 3;                    // fewer usable views: calibration fails, >= 2
  RobustLoss loss = RobustLoss::kNone;  // robust loss on each feature's reprojection error
  double loss_scale_px = 1.0;           // the loss's scale (pixels), > 0
  void Check() const;
};

// Parameter order of std_dev: fx fy cx cy k1 k2 p1 p2 k3 (0 for fixed parameters); the
// intrinsics block of bundle.h (kNumIntrinsics).

struct ViewResidual {
  std::string name;
  int num_features = 0;
  double rms_px = 0;
  double max_px = 0;
  bool used = false;
  std::string message;  // why a view was not used
};

// How a calibration ended: kSuccess needs enough usable views and a converged final solve with a
// finite RMS; every other value says what stopped it (the message gives the detail).
enum class CalibrationStatus {
  kSuccess,
  kTooFewViews,  // too few usable views (detections, features, pairs, or after rejection)
  kInitialisationFailed,
  kNotConverged,  // the final Ceres solve did not converge (summary.solve says how)
  kNotFinite,     // the reprojection RMS is not finite
  kCameraFailed,  // stereo: a single-camera calibration failed first
};
const char* ToString(CalibrationStatus s);

struct CalibrationSummary {
  // Until the calibration concludes; every return path sets it.
  CalibrationStatus status = CalibrationStatus::kTooFewViews;
  bool ok() const { return status == CalibrationStatus::kSuccess; }
  std::string message;
  int iterations = 0;  // Ceres iterations, all rounds
  SolveReport solve;   // the final Ceres solve: termination type, message, costs
  double initial_rms_px = 0;
  double final_rms_px = 0;
  int num_views_used = 0;
  int num_views_rejected = 0;
  int num_features = 0;  // used in the final solve
  std::vector<ViewResidual> views;
  std::string BriefReport() const;
};

struct CameraCalibration {
  CameraModel camera;
  std::vector<Rigid3d> camera_from_board;  // per input view (identity where unused)
  std::array<double, kNumIntrinsics> std_dev{};
  // Per view, per detected feature (in detection order): measured centre (after the last
  // re-measurement) and observed - projected residual; empty for unused views.
  std::vector<std::vector<Eigen::Vector2d>> centres_px, residuals_px;
  CalibrationSummary summary;
};

// views[i] are the detections of one camera; `names` (optional) label them in messages.
CameraCalibration CalibrateCamera(const std::vector<TargetDetection>& views,
                                  const CalibrationTarget& target, int width, int height,
                                  const CalibrationOptions& options = {},
                                  const std::vector<std::string>& names = {});

struct StereoCalibration {
  StereoRig rig;  // projector absent
  CameraCalibration left, right;
  std::vector<Rigid3d> left_from_board;       // per view pair (identity where unused)
  std::array<double, 6> extrinsic_std_dev{};  // rotation vector (rad) x y z, translation (mm)
  // Joint covariance (24 x 24) of the final solve's rig parameters: left intrinsics (9, the
  // order of std_dev), right intrinsics (9), right_from_left (rotation vector rad, translation
  // mm); coordinates held fixed have zero rows. Empty when it could not be computed.
  Eigen::MatrixXd rig_covariance;
  int num_pairs = 0;  // view pairs used jointly
  double rms_px = 0;  // joint reprojection RMS, both cameras
  double epipolar_rms_px = 0, epipolar_max_px = 0;
  CalibrationSummary summary;
  std::string BriefReport() const;
};

// right_width / right_height (> 0): the second device's image size when it differs from the
// first's (a projector as the second device, calib/projector.h).
StereoCalibration CalibrateStereo(const std::vector<TargetDetection>& left,
                                  const std::vector<TargetDetection>& right,
                                  const CalibrationTarget& target, int width, int height,
                                  const CalibrationOptions& options = {},
                                  const std::vector<std::string>& names = {}, int right_width = 0,
                                  int right_height = 0);

// Joint calibration of N devices (cameras, projectors as inverse cameras) that observe the same
// board poses: views[d][v] is device d's detection of pose v (not ok() where it did not see
// it). Each device is first calibrated alone (CalibrateCamera: Zhang + refinement), each
// device_from_reference (reference = device 0) starts from the robust medoid of its per-pose
// estimates, then one Ceres refinement of all intrinsics, the board poses and the
// device_from_reference poses (bundle.h), with view / outlier rejection as CalibrateStereo.
// A pose needs device 0 and at least one other device. sizes[d]: device d's image size.
struct MultiDeviceCalibration {
  std::vector<CameraCalibration> devices;      // per device, from the joint solution
  std::vector<Rigid3d> device_from_reference;  // [0] = identity
  // Per device: rotation vector (rad) x y z, translation (mm); [0] zeros.
  std::vector<std::array<double, 6>> extrinsic_std_dev;
  std::vector<Rigid3d> reference_from_board;  // per pose (identity where unused)
  std::vector<double> device_rms_px;          // per device, joint solution
  double rms_px = 0;                          // all devices
  CalibrationSummary summary;
  bool ok() const { return summary.ok(); }
};
MultiDeviceCalibration CalibrateDevices(const std::vector<std::vector<TargetDetection>>& views,
                                        const CalibrationTarget& target,
                                        const std::vector<cv::Size>& sizes,
                                        const CalibrationOptions& options = {},
                                        const std::vector<std::string>& names = {});

}  // namespace fringe::calib
