#include "fringe/stereo/triangulation.h"

#include <Eigen/Cholesky>
#include <cmath>

#include "fringe/util/error.h"

namespace fringe::stereo {
namespace {

// Pixel of p_in_cam and, when jac is not null, its 2x3 Jacobian with respect to p_in_cam.
Eigen::Vector2d ProjectWithJacobian(const CameraModel& cam, const Eigen::Vector3d& p,
                                    Eigen::Matrix<double, 2, 3>* jac) {
  const double inv_z = 1.0 / p.z();
  const Eigen::Vector2d xy(p.x() * inv_z, p.y() * inv_z);
  if (jac == nullptr) return cam.PixelFromNormalized(cam.Distort(xy));
  Eigen::Matrix<double, 2, 3> dxy_dp;
  dxy_dp << inv_z, 0, -xy.x() * inv_z, 0, inv_z, -xy.y() * inv_z;
  Eigen::Matrix2d f = Eigen::Matrix2d::Zero();
  f(0, 0) = cam.fx;
  f(1, 1) = cam.fy;
  *jac = f * cam.DistortJacobian(xy) * dxy_dp;
  return cam.PixelFromNormalized(cam.Distort(xy));
}

}  // namespace

void TriangulationOptions::Check() const {
  util::CheckOption(refine_iterations >= 0 && refine_iterations <= 20, "TriangulationOptions",
                    "refine_iterations", refine_iterations, "must be in [0, 20]");
  util::CheckOption(min_ray_angle_rad > 0 && min_ray_angle_rad < 1, "TriangulationOptions",
                    "min_ray_angle_rad", min_ray_angle_rad, "must be in (0, 1)");
}

const char* ToString(TriangulationStatus status) {
  switch (status) {
    case TriangulationStatus::kOk:
      return "ok";
    case TriangulationStatus::kParallelRays:
      return "parallel rays";
    case TriangulationStatus::kBehindCamera:
      return "behind camera";
  }
  return "?";
}

TriangulatedPoint TriangulateFromRays(const StereoRig& rig, const Eigen::Vector3d& ray_left,
                                      const Eigen::Vector2d& left_px,
                                      const Eigen::Vector2d& xy_right,
                                      const Eigen::Vector2d& right_px,
                                      const TriangulationOptions& options) {
  return RayTriangulator(rig, options).Triangulate(ray_left, left_px, xy_right, right_px);
}

RayTriangulator::RayTriangulator(const StereoRig& rig, const TriangulationOptions& options)
    : left_(rig.left),
      right_(rig.right),
      options_(options),
      left_from_right_(rig.right_from_left.Inverse()),
      r_rl_(rig.right_from_left.rotation_matrix()),
      t_rl_(rig.right_from_left.translation()),
      min_denom_(std::pow(std::sin(options.min_ray_angle_rad), 2)) {}

TriangulatedPoint RayTriangulator::Triangulate(const Eigen::Vector3d& ray_left,
                                               const Eigen::Vector2d& left_px,
                                               const Eigen::Vector2d& xy_right,
                                               const Eigen::Vector2d& right_px) const {
  TriangulatedPoint out;
  const Eigen::Vector3d& c_right = left_from_right_.translation();
  const Eigen::Vector3d d0 = ray_left.normalized();
  const Eigen::Vector3d d1 =
      left_from_right_.RotateDirection(Eigen::Vector3d(xy_right.x(), xy_right.y(), 1.0))
          .normalized();
  // Closest points of the rays s*d0 and c_right + t*d1.
  const double b = d0.dot(d1);
  const double denom = 1.0 - b * b;
  if (denom < min_denom_) {
    out.status = TriangulationStatus::kParallelRays;
    return out;
  }
  const double d = d0.dot(c_right), e = d1.dot(c_right);
  const double s = (d - b * e) / denom;
  const double t = (b * d - e) / denom;
  if (s <= 0 || t <= 0) {
    out.status = TriangulationStatus::kBehindCamera;
    return out;
  }
  Eigen::Vector3d p = 0.5 * (s * d0 + c_right + t * d1);

  const Eigen::Matrix3d& r_rl = r_rl_;
  const Eigen::Vector3d& t_rl = t_rl_;
  double sq_error = 0;
  for (int it = 0; it <= options_.refine_iterations; ++it) {
    Eigen::Matrix<double, 2, 3> jl, jr;
    const Eigen::Vector3d p_right = r_rl * p + t_rl;
    if (p.z() <= 0 || p_right.z() <= 0) {
      out.status = TriangulationStatus::kBehindCamera;
      return out;
    }
    // The last pass only measures the residual: no Jacobians.
    const bool last = it == options_.refine_iterations;
    const Eigen::Vector2d el = ProjectWithJacobian(left_, p, last ? nullptr : &jl) - left_px;
    const Eigen::Vector2d er =
        ProjectWithJacobian(right_, p_right, last ? nullptr : &jr) - right_px;
    sq_error = el.squaredNorm() + er.squaredNorm();
    if (last) break;
    jr = jr * r_rl;
    const Eigen::Matrix3d h = jl.transpose() * jl + jr.transpose() * jr;
    const Eigen::Vector3d g = jl.transpose() * el + jr.transpose() * er;
    p -= h.ldlt().solve(g);
  }
  out.status = TriangulationStatus::kOk;
  out.p_in_left = p;
  out.reprojection_error_px = std::sqrt(0.5 * sq_error);
  return out;
}

TriangulatedPoint Triangulate(const StereoRig& rig, const Eigen::Vector2d& left_px,
                              const Eigen::Vector2d& right_px,
                              const TriangulationOptions& options) {
  return TriangulateFromRays(rig, rig.left.Ray(left_px), left_px, rig.right.Unproject(right_px),
                             right_px, options);
}

}  // namespace fringe::stereo
