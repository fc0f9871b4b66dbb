// Sensor poses for multi-view scans and where the rig looks.
//
// Frames: world (the scene's, z up), sensor = left camera. Every function returns
// world_from_sensor, the ground-truth pose of a view. A turntable scan (the part rotates about
// the world z axis in front of a fixed sensor) is expressed the same way, with world = the
// part's frame.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "fringe/geometry/rigid3.h"
#include "fringe/geometry/stereo_rig.h"

namespace fringe::sim {

// The point, in the sensor frame, where the two cameras' optical axes come closest: the centre
// of the measuring volume (about 500 mm in front of the reference rig).
Eigen::Vector3d WorkingPoint(const StereoRig& rig);

// world_from_sensor putting the rig's working point on target_in_world, the sensor looking
// along -from_dir (from_dir: unit direction from the target toward the sensor), image "down"
// as close to world -z as possible (world +y when looking straight down), rolled by roll_rad
// about the viewing axis, and standoff_mm added along from_dir (negative: closer).
Rigid3d SensorPoseLookingAt(const StereoRig& rig, const Eigen::Vector3d& target_in_world,
                            const Eigen::Vector3d& from_dir, double roll_rad = 0,
                            double standoff_mm = 0);

struct OrbitOptions {
  int views = 8;                     // number of views, >= 1
  bool turntable = false;            // true: the part turns about world z; false: sensor moves
  double elevation_deg = 55;         // viewing direction above the horizontal plane, (0, 90]
  double elevation_jitter_deg = 10;  // uniform +- jitter of the elevation, >= 0
  double azimuth_start_deg = 0;      // azimuth of the first view
  double azimuth_jitter_deg = 5;     // uniform +- jitter of each azimuth, >= 0
  double roll_jitter_deg = 10;       // uniform +- roll about the viewing axis, >= 0
  double standoff_jitter_mm = 20;    // uniform +- change of the working distance, >= 0
  uint64_t seed = 1;

  void Check() const;
};

// Views evenly spread in azimuth around target_in_world (sensor moving), or the part turned on
// a turntable by 360/views degrees per view with the sensor fixed at azimuth_start (the jitters
// then apply to the fixed sensor of view 0 only). Deterministic for a seed.
std::vector<Rigid3d> OrbitPoses(const StereoRig& rig, const Eigen::Vector3d& target_in_world,
                                const OrbitOptions& options = {});

}  // namespace fringe::sim
