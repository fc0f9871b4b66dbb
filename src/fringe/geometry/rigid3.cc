#include "fringe/geometry/rigid3.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <ostream>

namespace fringe {
namespace {

Eigen::Matrix3d NearestRotation(const Eigen::Matrix3d& m) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

}  // namespace

Rigid3d::Rigid3d(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation)
    : rotation_(Eigen::Quaterniond(NearestRotation(rotation)).normalized()),
      translation_(translation) {}

Rigid3d Rigid3d::FromMatrix(const Eigen::Matrix<double, 3, 4>& m) {
  return Rigid3d(Eigen::Matrix3d(m.leftCols<3>()), Eigen::Vector3d(m.col(3)));
}

Rigid3d Rigid3d::FromAxisAngle(const Eigen::Vector3d& axis, double angle_rad,
                               const Eigen::Vector3d& translation) {
  return Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(angle_rad, axis.normalized())), translation);
}

Eigen::Matrix<double, 3, 4> Rigid3d::ToMatrix3x4() const {
  Eigen::Matrix<double, 3, 4> m;
  m.leftCols<3>() = rotation_matrix();
  m.col(3) = translation_;
  return m;
}

Eigen::Matrix4d Rigid3d::ToMatrix4() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topRows<3>() = ToMatrix3x4();
  return m;
}

Rigid3d Rigid3d::Inverse() const {
  const Eigen::Quaterniond inv = rotation_.conjugate();
  return Rigid3d(inv, -(inv * translation_));
}

double Rigid3d::AngleRad() const {
  // atan2 form is accurate for tiny angles, unlike acos(w).
  const double s = rotation_.vec().norm();
  return 2.0 * std::atan2(s, std::abs(rotation_.w()));
}

std::ostream& operator<<(std::ostream& os, const Rigid3d& t) {
  const Eigen::Quaterniond& q = t.rotation();
  return os << "Rigid3d(q_wxyz=[" << q.w() << ", " << q.x() << ", " << q.y() << ", " << q.z()
            << "], t_mm=[" << t.translation().transpose() << "])";
}

RigidDifference Difference(const Rigid3d& a, const Rigid3d& b) {
  const Rigid3d d = a.Inverse() * b;
  return {d.AngleRad(), (a.translation() - b.translation()).norm()};
}

}  // namespace fringe
