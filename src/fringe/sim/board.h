// Calibration board images with exact ground truth.
//
// The board (fringe::CalibrationTarget: concentric rings with distinct centre dots, circle
// grids, chessboards) is rendered from its analytic albedo on the plane z = 0 of the board frame
// under uniform illumination: each pixel is the box-filtered albedo over its footprint. Pixels
// whose four corners and centre see the same albedo are uniform; the others (edge pixels) are
// averaged over n x n samples (edges_supersampling), so edges are anti-aliased to ~1/n^2 of the
// intensity step. Then the camera sensor model (renderer.h: ApplySensor) adds noise and
// quantises.
//
// Ground truth: the TRUE projected feature centres camera.Project(cam_from_board * centre)
// (not ellipse centres, which are biased under perspective), per feature, row-major.
//
// Frames: board frame as in calibration_target.h (origin at feature (0, 0), z = 0 on the board,
// the printed side faces -z); cam_from_board maps board points into the camera frame; for a rig,
// poses are left_from_board (sensor frame). Thread safety: free functions, reentrant.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "fringe/geometry/calibration_target.h"
#include "fringe/geometry/camera.h"
#include "fringe/geometry/rigid3.h"
#include "fringe/geometry/stereo_rig.h"
#include "fringe/sim/renderer.h"

namespace fringe::sim {

struct BoardRenderOptions {
  SensorOptions sensor;            // noise, bit depth, exposure (sensor.supersampling unused)
  int edge_supersampling = 8;      // n: n x n samples in pixels crossed by an edge, [1, 32]
  double white_albedo = 0.85;      // printed white, [0, 1]
  double black_albedo = 0.05;      // printed black, [0, 1]
  double background_albedo = 0.2;  // beyond the board, [0, 1]
  double illumination = 1.0;       // uniform radiance on the board (white projector), >= 0

  void Check() const;
};

struct BoardImage {
  cv::Mat image;  // CV_8U / CV_16U (CV_32F with sensor.float_output)
  Rigid3d cam_from_board;
  // True projected centre of every feature (row-major, index = row * cols + col); NaN behind
  // the camera.
  std::vector<Eigen::Vector2d> centres_px;
  // 1 where the whole feature (its outer circle, or the chessboard corner's four adjacent half
  // squares) lies inside the image and the board faces the camera.
  std::vector<uint8_t> visible;

  int NumVisible() const;
};

// Albedo of the printed board at (x, y) in the board frame (mm): white, black, or the
// background beyond the board's extent.
double BoardAlbedo(const CalibrationTarget& target, double x_mm, double y_mm,
                   const BoardRenderOptions& options);

// Renders one camera's image of the board. `stream` selects the noise stream.
BoardImage RenderBoardImage(const CameraModel& camera, const CalibrationTarget& target,
                            const Rigid3d& cam_from_board, const BoardRenderOptions& options = {},
                            uint64_t stream = 0);

struct StereoBoardImages {
  BoardImage left;
  BoardImage right;
};
// Both cameras of the rig for a board pose in the sensor (left camera) frame; `index` selects
// the noise streams.
StereoBoardImages RenderStereoBoard(const StereoRig& rig, const CalibrationTarget& target,
                                    const Rigid3d& left_from_board,
                                    const BoardRenderOptions& options = {}, uint64_t index = 0);

// Which features of `target` are fully visible in `camera` at cam_from_board (see
// BoardImage::visible).
std::vector<uint8_t> VisibleFeatures(const CameraModel& camera, const CalibrationTarget& target,
                                     const Rigid3d& cam_from_board);

struct BoardPoseOptions {
  int count = 20;                     // number of poses, >= 1
  double min_distance_mm = 420;       // board centre distance from the left camera, > 0
  double max_distance_mm = 600;       // >= min_distance_mm
  double max_tilt_deg = 60;           // largest angle between board normal and view axis, [0, 85]
  double max_roll_deg = 30;           // largest in-plane rotation, [0, 180]
  double min_visible_fraction = 0.5;  // of all features, in every required camera, (0, 1]
  bool both_cameras = true;           // require visibility in the right camera too
  uint64_t seed = 1;

  void Check() const;
};

// Varied, seeded board poses left_from_board: the board centre aimed at points spread over the
// whole left image (a jittered 3 x 3 grid cycled over the poses, so every part of the image is
// covered and poses near the edges show the board partly), tilted about a random in-plane axis
// by up to max_tilt_deg (tilt angles spread uniformly), rolled, at a random distance. Poses
// failing the visibility requirement are redrawn. Throws fringe::Error when no valid pose is
// found after many attempts (e.g. a board much larger than the field of view).
std::vector<Rigid3d> GenerateBoardPoses(const StereoRig& rig, const CalibrationTarget& target,
                                        const BoardPoseOptions& options = {});

}  // namespace fringe::sim
