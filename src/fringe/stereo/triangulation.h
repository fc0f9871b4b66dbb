// Two-view triangulation in the original (distorted) image geometry of a calibrated rig.
//
// Frames and units (docs/conventions.md): pixels are original camera pixels (lens distortion
// included, centre of the top-left pixel at (0, 0)); the returned point is in the LEFT camera
// frame (= sensor frame) in millimetres.
//
// Method: the midpoint of the shortest segment between the two viewing rays (rays from
// CameraModel::Unproject, right ray moved into the left frame with rig.right_from_left), then,
// when refine_iterations > 0, Gauss-Newton on the sum of squared reprojection errors in both
// images through the full distortion model ("gold standard" optimal triangulation, Hartley &
// Zisserman, Multiple View Geometry, 2nd ed., sec. 12.1/12.3, with the 3D point as the only
// unknown). The RMS reprojection residual over the two images is kept.
//
// Thread safety: free functions without shared state; safe to call concurrently.
#pragma once

#include <Eigen/Core>

#include "fringe/geometry/stereo_rig.h"

namespace fringe::stereo {

struct TriangulationOptions {
  // Gauss-Newton iterations on the reprojection error after the midpoint; 0 = midpoint only.
  // Range [0, 20].
  int refine_iterations = 2;
  // Rays closer to parallel than this angle are rejected (degenerate geometry), radians, > 0.
  double min_ray_angle_rad = 1e-3;

  void Check() const;
};

enum class TriangulationStatus {
  kOk = 0,
  kParallelRays,  // the rays are (nearly) parallel: depth undetermined
  kBehindCamera,  // the intersection lies behind one of the cameras
};

struct TriangulatedPoint {
  TriangulationStatus status = TriangulationStatus::kParallelRays;
  Eigen::Vector3d p_in_left = Eigen::Vector3d::Zero();  // mm, left camera frame
  // RMS over the two images of the reprojection error, pixels.
  double reprojection_error_px = 0;
  bool ok() const { return status == TriangulationStatus::kOk; }
};

// Triangulates one correspondence given in original (distorted) pixels.
TriangulatedPoint Triangulate(const StereoRig& rig, const Eigen::Vector2d& left_px,
                              const Eigen::Vector2d& right_px,
                              const TriangulationOptions& options = {});

// Same, with the left and right viewing directions already known: ray_left in the left frame,
// xy_right = undistorted normalized coordinates of the right pixel. Used by the matcher, which
// caches the left rays per pixel.
TriangulatedPoint TriangulateFromRays(const StereoRig& rig, const Eigen::Vector3d& ray_left,
                                      const Eigen::Vector2d& left_px,
                                      const Eigen::Vector2d& xy_right,
                                      const Eigen::Vector2d& right_px,
                                      const TriangulationOptions& options);

// TriangulateFromRays for many correspondences of one rig: the rig-only quantities (left from
// right transform, its rotation matrix, the parallel-ray bound) computed once instead of per
// point, with the same arithmetic, so results are bit-identical to TriangulateFromRays (the
// matcher calls it once per matched pixel). Immutable; safe to use concurrently.
class RayTriangulator {
 public:
  RayTriangulator(const StereoRig& rig, const TriangulationOptions& options);
  TriangulatedPoint Triangulate(const Eigen::Vector3d& ray_left, const Eigen::Vector2d& left_px,
                                const Eigen::Vector2d& xy_right,
                                const Eigen::Vector2d& right_px) const;

 private:
  CameraModel left_, right_;
  TriangulationOptions options_;
  Rigid3d left_from_right_;
  Eigen::Matrix3d r_rl_;
  Eigen::Vector3d t_rl_;
  double min_denom_ = 0;  // sin(min_ray_angle_rad)^2
};

const char* ToString(TriangulationStatus status);

}  // namespace fringe::stereo
