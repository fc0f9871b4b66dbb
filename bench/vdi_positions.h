// The VDI/VDE 2634-2 artefacts and their positions in the reference rig's measuring volume,
// shared by bench_reconstruction (stereo) and bench_camera_projector so that both measure the
// same views: sphere d = 30 mm in up to 10 positions (spread over the field of view and the
// depth of field, +-60 mm), ball bar 200 mm in up to 7 orientations, plate in up to 6.
// Poses are world_from_sensor for the scenes of sim::MakeSphereScene / MakeBallBarScene /
// MakePlateScene.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>

#include "fringe/geometry/rigid3.h"
#include "fringe/geometry/stereo_rig.h"
#include "fringe/sim/poses.h"

namespace fringe::bench {

constexpr double kSphereRadiusMm = 15;
constexpr double kBarRadiusMm = 12.5;
constexpr double kBarDistanceMm = 200;

// Sphere position k of n; its centre in the world is SphereCentre().
inline Eigen::Vector3d SphereCentre() { return Eigen::Vector3d(0, 0, kSphereRadiusMm); }
inline Rigid3d SpherePose(const StereoRig& rig, int k, int n) {
  const double ax = -70 + 140.0 * (k % 5) / 4, ay = (k / 5 % 2 ? 45 : -45);
  const double standoff = -60 + 120.0 * k / std::max(1, n - 1);
  return sim::SensorPoseLookingAt(rig, SphereCentre() + Eigen::Vector3d(ax, ay, 0),
                                  Eigen::Vector3d(0.1 * (k % 3 - 1), -0.45, 1).normalized(),
                                  0.2 * k, standoff);
}

// Ball bar orientation k of n: roll about the view axis and tilt in depth.
inline Rigid3d BallBarPose(const StereoRig& rig, int k, int n) {
  const double roll = M_PI * k / n;
  const Eigen::Vector3d from = Eigen::Vector3d(0.35 * std::sin(1.3 * k), -0.4, 1).normalized();
  return sim::SensorPoseLookingAt(rig, Eigen::Vector3d(0, 0, 40), from, roll, -40 + 15.0 * k);
}

// Plate position k of n.
inline Rigid3d PlatePose(const StereoRig& rig, int k, int n) {
  const double roll = M_PI * k / n;
  const Eigen::Vector3d from = Eigen::Vector3d(0.3 * std::cos(1.7 * k), -0.3, 1).normalized();
  return sim::SensorPoseLookingAt(rig, Eigen::Vector3d::Zero(), from, roll, -50 + 20.0 * k);
}

}  // namespace fringe::bench
