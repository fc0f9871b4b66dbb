// Rigid transforms in 3D.
//
// Naming (docs/conventions.md): a transform is named b_from_a and maps a point expressed in frame
// a to frame b: p_in_b = b_from_a * p_in_a = R * p_in_a + t. Composition reads right to left:
// c_from_a = c_from_b * b_from_a. Lengths are millimetres.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <iosfwd>

namespace fringe {

class Rigid3d {
 public:
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW

  Rigid3d() : rotation_(Eigen::Quaterniond::Identity()), translation_(Eigen::Vector3d::Zero()) {}
  Rigid3d(const Eigen::Quaterniond& rotation, const Eigen::Vector3d& translation)
      : rotation_(rotation.normalized()), translation_(translation) {}
  Rigid3d(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation);

  static Rigid3d Identity() { return Rigid3d(); }
  // From a 3x4 [R | t] or 4x4 homogeneous matrix; R is orthonormalised (nearest rotation).
  static Rigid3d FromMatrix(const Eigen::Matrix<double, 3, 4>& m);
  // Rotation about a unit axis by angle_rad, then translation.
  static Rigid3d FromAxisAngle(const Eigen::Vector3d& axis, double angle_rad,
                               const Eigen::Vector3d& translation = Eigen::Vector3d::Zero());

  const Eigen::Quaterniond& rotation() const { return rotation_; }
  Eigen::Matrix3d rotation_matrix() const { return rotation_.toRotationMatrix(); }
  const Eigen::Vector3d& translation() const { return translation_; }
  Eigen::Matrix<double, 3, 4> ToMatrix3x4() const;
  Eigen::Matrix4d ToMatrix4() const;

  Rigid3d Inverse() const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return rotation_ * p + translation_; }
  Rigid3d operator*(const Rigid3d& other) const {
    return Rigid3d(rotation_ * other.rotation_, rotation_ * other.translation_ + translation_);
  }
  // Rotates a direction (normal) without translating it.
  Eigen::Vector3d RotateDirection(const Eigen::Vector3d& d) const { return rotation_ * d; }

  // Rotation angle of this transform in radians, in [0, pi].
  double AngleRad() const;

 private:
  Eigen::Quaterniond rotation_;
  Eigen::Vector3d translation_;
};

std::ostream& operator<<(std::ostream& os, const Rigid3d& t);

// Rotation angle (rad) and translation distance (mm) between two transforms: how far apart
// a and b are, as used by tests and registration summaries.
struct RigidDifference {
  double angle_rad = 0;
  double translation_mm = 0;
};
RigidDifference Difference(const Rigid3d& a, const Rigid3d& b);

}  // namespace fringe
