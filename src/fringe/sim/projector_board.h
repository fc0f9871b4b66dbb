// Calibration boards lit by the projector's fringe patterns: what a camera sees of a
// board while the projector casts each image of a pattern scheme, for projector calibration
// (calib/projector.h) scored against the true projector.
//
// Model (the board frame, albedos and sensor of board.h; the projector model of renderer.h with
// a linear response): per camera sample ray, supersampled on an n x n grid inside each pixel and
// box-averaged, the ray meets the board plane at p; radiance = albedo(p) * (ambient +
// illumination * P(u, v)), where (u, v) = projector.Project(projector_from_camera * p) (distorted
// projector model) and P the pattern bilinearly interpolated (0 outside the projector image or
// behind it). Patterns are CV_8U (0..255) or CV_32F (0..1) of the projector's size; decode them
// with gamma 1 (phase::GeneratePatterns without pre-compensation). No shadows (a plane).
//
// Ground truth: the projector pixel of feature (r, c) is
// projector.Project(projector_from_camera * cam_from_board * target.FeatureCentre(r, c)).
// Noise: pattern k uses the stream util::MixSeed(stream, k) of the sensor (renderer.h:
// ApplySensor), so results do not depend on the thread count. Thread safety: reentrant.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "fringe/geometry/calibration_target.h"
#include "fringe/geometry/camera.h"
#include "fringe/geometry/rigid3.h"
#include "fringe/geometry/stereo_rig.h"
#include "fringe/phase/decode.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/sim/board.h"

namespace fringe::sim {

struct FringeBoardOptions {
  BoardRenderOptions board;  // albedos and sensor; board.illumination = a white projector pixel
  double ambient = 0.05;     // radiance without the projector (fraction of white), >= 0
  int supersampling = 3;     // n x n samples per camera pixel, [1, 8]
  void Check() const;
};

// The camera's image of the board under each pattern, in order.
std::vector<cv::Mat> RenderBoardUnderPatterns(
    const CameraModel& camera, const CameraModel& projector, const Rigid3d& projector_from_camera,
    const CalibrationTarget& target, const Rigid3d& cam_from_board,
    const std::vector<cv::Mat>& patterns, const FringeBoardOptions& options = {},
    uint64_t stream = 0);

// A scheme preset (phase/scheme_presets.h) for `projector` in both directions:
// {vertical fringes (phase = column), horizontal fringes (phase = row)}.
std::array<phase::PatternScheme, 2> BothDirectionSchemes(
    const CameraModel& projector, const std::string& preset = "heterodyne-4x3");

// One board pose under both schemes (BothDirectionSchemes), rendered and decoded with gamma 1:
// the camera's projector columns and rows. Noise streams 2 * index + 100 and 2 * index + 101.
std::array<phase::DecodeResult, 2> DecodeBoardUnderBothDirections(
    const CameraModel& camera, const CameraModel& projector, const Rigid3d& projector_from_camera,
    const CalibrationTarget& target, const Rigid3d& cam_from_board,
    const std::array<phase::PatternScheme, 2>& schemes, const FringeBoardOptions& options,
    uint64_t index);

// A projector calibration folder as `fringe calibrate` reads it (docs/scan-folder.md): per board
// pose KKK (000, 001, ...) the plain board image and the fringe stacks of both directions with
// their manifests, in DIR/KKK/ (one camera: the left) or DIR/KKK/left/ and DIR/KKK/right/
// (two_cameras), and DIR/target.json. The board poses (left_from_board) are returned; the
// truth is the rig given. Images: plain board stream = pose index (+1000 for the right
// camera), fringe stacks 100 + 2 * index + direction (+1000 right).
struct ProjectorCalibrationFolderOptions {
  BoardPoseOptions poses;      // count, seed, distances; both_cameras follows two_cameras
  FringeBoardOptions fringes;  // albedos, ambient, supersampling
  std::string preset = "heterodyne-4x3";  // scheme preset of both directions
  bool two_cameras = false;
  void Check() const;
};
std::vector<Rigid3d> WriteProjectorCalibrationFolder(
    const StereoRig& rig, const CalibrationTarget& target, const std::filesystem::path& dir,
    const ProjectorCalibrationFolderOptions& options = {});

}  // namespace fringe::sim
