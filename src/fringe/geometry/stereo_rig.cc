#include "fringe/geometry/stereo_rig.h"

#include <limits>

#include "fringe/util/error.h"

namespace fringe {
namespace {

// cam_from_rig for a camera at `centre_in_rig` looking at `target_in_rig` with its y axis
// pointing "down" (rig +y).
Rigid3d LookAt(const Eigen::Vector3d& centre_in_rig, const Eigen::Vector3d& target_in_rig) {
  const Eigen::Vector3d z = (target_in_rig - centre_in_rig).normalized();
  const Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d rig_from_cam_rot;
  rig_from_cam_rot << x, y, z;
  return Rigid3d(rig_from_cam_rot, centre_in_rig).Inverse();
}

}  // namespace

StereoRig StereoRig::Reference() {
  StereoRig rig;
  rig.left = CameraModel::ReferenceCamera();
  rig.right = CameraModel::ReferenceCamera();
  // Two lenses are never identical.
  rig.right.fx += 6.0;
  rig.right.fy += 5.0;
  rig.right.cx -= 4.1;
  rig.right.cy += 1.9;
  rig.right.k1 = -0.075;
  rig.right.k2 = 0.10;
  rig.right.p1 = -6.0e-5;
  rig.right.p2 = 8.0e-5;
  rig.projector = CameraModel::ReferenceProjector();

  const Eigen::Vector3d target(0, 0, 500);
  const Rigid3d left_from_rig = LookAt({-100, 0, 0}, target);
  const Rigid3d right_from_rig = LookAt({100, 0, 0}, target);
  // Projector slightly above the baseline, as in real heads where it sits between the cameras.
  const Rigid3d projector_from_rig = LookAt({0, -20, 0}, target);
  rig.right_from_left = right_from_rig * left_from_rig.Inverse();
  rig.projector_from_left = projector_from_rig * left_from_rig.Inverse();
  return rig;
}

void StereoRig::Check() const {
  left.Check();
  right.Check();
  if (projector) projector->Check();
  util::CheckOption(BaselineMm() > 0, "StereoRig", "right_from_left.translation", BaselineMm(),
                    "baseline must be > 0 mm");
}

double SignedEpipolarDistancePx(const StereoRig& rig, const Eigen::Vector2d& left_px,
                                const Eigen::Vector2d& right_px) {
  const Eigen::Vector2d xl = rig.left.Unproject(left_px);
  const Eigen::Vector2d xr = rig.right.Unproject(right_px);
  const Eigen::Matrix3d R = rig.right_from_left.rotation_matrix();
  const Eigen::Vector3d& t = rig.right_from_left.translation();
  Eigen::Matrix3d tx;
  tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  const Eigen::Vector3d line = (tx * R) * Eigen::Vector3d(xl.x(), xl.y(), 1);
  const double norm = line.head<2>().norm();
  if (norm <= 0) return std::numeric_limits<double>::infinity();
  return line.dot(Eigen::Vector3d(xr.x(), xr.y(), 1)) / norm * rig.right.fx;
}

}  // namespace fringe
