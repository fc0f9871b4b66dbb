// The sensor head: two cameras and, optionally, a calibrated projector.
//
// The sensor frame is the left camera frame: right_from_left maps points from the left camera
// frame to the right one, projector_from_left to the projector's. Lengths in millimetres.
#pragma once

#include <optional>

#include "fringe/geometry/camera.h"
#include "fringe/geometry/rigid3.h"

namespace fringe {

struct StereoRig {
  CameraModel left;
  CameraModel right;
  Rigid3d right_from_left;
  // Present when the projector is calibrated (simulator rigs, camera-projector mode).
  std::optional<CameraModel> projector;
  Rigid3d projector_from_left;

  // The reference rig of ../shared/SPEC.md: baseline 200 mm, optical axes converging at 500 mm
  // in front of the sensor, projector midway between the cameras aimed at the same point.
  static StereoRig Reference();

  // Throws fringe::Error when a camera is invalid or the baseline is zero.
  void Check() const;

  double BaselineMm() const { return right_from_left.translation().norm(); }
};

// Signed distance of right_px to the epipolar line of left_px in the right image, pixels (the
// lens distortion removed; the sign is the side of the line): a drifted camera moves every pair
// to the same side, noise to both sides (pipeline/drift.h, calib/refine_rig.h).
double SignedEpipolarDistancePx(const StereoRig& rig, const Eigen::Vector2d& left_px,
                                const Eigen::Vector2d& right_px);

}  // namespace fringe
