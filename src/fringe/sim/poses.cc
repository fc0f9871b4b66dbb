#include "fringe/sim/poses.h"

#include <cmath>
#include <random>

#include "fringe/util/error.h"
#include "fringe/util/random.h"

namespace fringe::sim {

namespace {
constexpr double kDeg = 3.14159265358979323846 / 180.0;
}

Eigen::Vector3d WorkingPoint(const StereoRig& rig) {
  // Closest points of the two optical axes (left: origin + s a; right: c + u b), in the left frame.
  const Rigid3d left_from_right = rig.right_from_left.Inverse();
  const Eigen::Vector3d a = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d c = left_from_right.translation();
  const Eigen::Vector3d b = left_from_right.RotateDirection(Eigen::Vector3d::UnitZ());
  const double ab = a.dot(b);
  const double den = 1 - ab * ab;
  if (den < 1e-9) return Eigen::Vector3d(c.x() / 2, c.y() / 2, 500.0);  // parallel axes
  const double s = (a.dot(c) - ab * b.dot(c)) / den;
  const double u = (ab * a.dot(c) - b.dot(c)) / den;
  return 0.5 * (s * a + c + u * b);
}

Rigid3d SensorPoseLookingAt(const StereoRig& rig, const Eigen::Vector3d& target_in_world,
                            const Eigen::Vector3d& from_dir, double roll_rad, double standoff_mm) {
  const Eigen::Vector3d working = WorkingPoint(rig);
  const Eigen::Vector3d mid = 0.5 * rig.right_from_left.Inverse().translation();
  // Sensor frame basis: viewing axis, image down, image right.
  const Eigen::Vector3d axis_s = (working - mid).normalized();
  const Eigen::Vector3d down_s =
      (Eigen::Vector3d::UnitY() - Eigen::Vector3d::UnitY().dot(axis_s) * axis_s).normalized();
  const Eigen::Vector3d right_s = down_s.cross(axis_s);
  // World basis.
  const Eigen::Vector3d axis_w = -from_dir.normalized();
  Eigen::Vector3d hint = -Eigen::Vector3d::UnitZ();
  if (std::abs(hint.dot(axis_w)) > 0.999) hint = Eigen::Vector3d::UnitY();
  Eigen::Vector3d down_w = (hint - hint.dot(axis_w) * axis_w).normalized();
  down_w = Eigen::AngleAxisd(roll_rad, axis_w) * down_w;
  const Eigen::Vector3d right_w = down_w.cross(axis_w);
  Eigen::Matrix3d s, w;
  s << axis_s, down_s, right_s;
  w << axis_w, down_w, right_w;
  const Eigen::Matrix3d world_from_sensor_rot = w * s.transpose();
  const Eigen::Vector3d t =
      target_in_world - world_from_sensor_rot * working - standoff_mm * axis_w;
  return Rigid3d(world_from_sensor_rot, t);
}

void OrbitOptions::Check() const {
  using util::CheckOption;
  CheckOption(views >= 1, "OrbitOptions", "views", views, "must be >= 1");
  CheckOption(elevation_deg > 0 && elevation_deg <= 90, "OrbitOptions", "elevation_deg",
              elevation_deg, "must be in (0, 90]");
  CheckOption(elevation_jitter_deg >= 0, "OrbitOptions", "elevation_jitter_deg",
              elevation_jitter_deg, "must be >= 0");
  CheckOption(azimuth_jitter_deg >= 0, "OrbitOptions", "azimuth_jitter_deg", azimuth_jitter_deg,
              "must be >= 0");
  CheckOption(roll_jitter_deg >= 0, "OrbitOptions", "roll_jitter_deg", roll_jitter_deg,
              "must be >= 0");
  CheckOption(standoff_jitter_mm >= 0, "OrbitOptions", "standoff_jitter_mm", standoff_jitter_mm,
              "must be >= 0");
}

std::vector<Rigid3d> OrbitPoses(const StereoRig& rig, const Eigen::Vector3d& target,
                                const OrbitOptions& opt) {
  opt.Check();
  std::vector<Rigid3d> poses;
  auto pose_at = [&](int i, double azimuth_deg) {
    util::Rng rng(util::MixSeed(opt.seed, static_cast<uint64_t>(i)));
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    const double el =
        std::min(90.0, opt.elevation_deg + opt.elevation_jitter_deg * unit(rng)) * kDeg;
    const double az = (azimuth_deg + opt.azimuth_jitter_deg * unit(rng)) * kDeg;
    const double roll = opt.roll_jitter_deg * unit(rng) * kDeg;
    const double standoff = opt.standoff_jitter_mm * unit(rng);
    // From the target toward the sensor; azimuth 0 = sensor on the -y side of the part.
    const Eigen::Vector3d from(std::cos(el) * std::sin(az), -std::cos(el) * std::cos(az),
                               std::sin(el));
    return SensorPoseLookingAt(rig, target, from, roll, standoff);
  };
  if (opt.turntable) {
    const Rigid3d fixed = pose_at(0, opt.azimuth_start_deg);
    for (int i = 0; i < opt.views; ++i) {
      // The part turned by +angle equals the sensor turned by -angle about the table axis.
      const double angle = -2.0 * 3.14159265358979323846 * i / opt.views;
      const Rigid3d turn =
          Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ())),
                  Eigen::Vector3d::Zero());
      const Rigid3d about_target =
          Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(target.x(), target.y(), 0)) *
          turn *
          Rigid3d(Eigen::Quaterniond::Identity(), -Eigen::Vector3d(target.x(), target.y(), 0));
      poses.push_back(about_target * fixed);
    }
  } else {
    for (int i = 0; i < opt.views; ++i) {
      poses.push_back(pose_at(i, opt.azimuth_start_deg + 360.0 * i / opt.views));
    }
  }
  return poses;
}

}  // namespace fringe::sim
