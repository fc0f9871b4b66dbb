// Test-only helpers: analytic scenes (spheres and planes) ray traced exactly, giving the absolute
// phase (projector column) each camera pixel sees and the true 3D point, without a renderer.
// Frames: everything in the LEFT camera frame, millimetres.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <vector>

#include "fringe/geometry/stereo_rig.h"

namespace fringe::stereo::testing {

struct Sphere {
  Eigen::Vector3d centre;
  double radius;
};
struct Plane {
  Eigen::Vector3d normal;  // unit
  double offset;           // points x with normal . x = offset
};

struct Scene {
  std::vector<Sphere> spheres;
  std::vector<Plane> planes;

  // Smallest t > eps with origin + t dir on a surface; infinity when none.
  double Hit(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const {
    double best = std::numeric_limits<double>::infinity();
    for (const Sphere& s : spheres) {
      const Eigen::Vector3d oc = o - s.centre;
      const double b = oc.dot(d), c = oc.squaredNorm() - s.radius * s.radius;
      const double disc = b * b - c;
      if (disc < 0) continue;
      const double sq = std::sqrt(disc);
      for (double t : {-b - sq, -b + sq}) {
        if (t > 1e-6 && t < best) best = t;
      }
    }
    for (const Plane& p : planes) {
      const double den = p.normal.dot(d);
      if (std::abs(den) < 1e-12) continue;
      const double t = (p.offset - p.normal.dot(o)) / den;
      if (t > 1e-6 && t < best) best = t;
    }
    return best;
  }
};

// Rig with every device's image scaled by `s` (pixel centres kept consistent).
inline CameraModel ScaleCamera(CameraModel c, double s) {
  c.width = static_cast<int>(std::lround(c.width * s));
  c.height = static_cast<int>(std::lround(c.height * s));
  c.fx *= s;
  c.fy *= s;
  c.cx = (c.cx + 0.5) * s - 0.5;
  c.cy = (c.cy + 0.5) * s - 0.5;
  return c;
}
inline StereoRig ScaledReferenceRig(double s) {
  StereoRig rig = StereoRig::Reference();
  rig.left = ScaleCamera(rig.left, s);
  rig.right = ScaleCamera(rig.right, s);
  rig.projector = ScaleCamera(*rig.projector, s);
  return rig;
}

struct TrueView {
  cv::Mat phase;  // CV_32F projector column, NaN where not lit / no surface
  std::vector<Eigen::Vector3d> p_in_left;  // per pixel, NaN where no surface
};

// Traces camera `right ? right : left` of the rig against the scene; the projector lights a
// point when its own ray reaches the point first.
inline TrueView TraceView(const StereoRig& rig, const Scene& scene, bool right) {
  const CameraModel& cam = right ? rig.right : rig.left;
  const Rigid3d left_from_cam = right ? rig.right_from_left.Inverse() : Rigid3d();
  const Rigid3d left_from_projector = rig.projector_from_left.Inverse();
  TrueView v;
  v.phase =
      cv::Mat(cam.height, cam.width, CV_32FC1, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  v.p_in_left.assign(static_cast<size_t>(cam.width) * cam.height,
                     Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()));
  for (int r = 0; r < cam.height; ++r) {
    for (int c = 0; c < cam.width; ++c) {
      const Eigen::Vector3d o = left_from_cam.translation();
      const Eigen::Vector3d d = left_from_cam.RotateDirection(cam.Ray(Eigen::Vector2d(c, r)));
      const double t = scene.Hit(o, d);
      if (!std::isfinite(t)) continue;
      const Eigen::Vector3d p = o + t * d;
      v.p_in_left[static_cast<size_t>(r) * cam.width + c] = p;
      const Eigen::Vector3d po = left_from_projector.translation();
      const Eigen::Vector3d pd = (p - po).normalized();
      if (std::abs(scene.Hit(po, pd) - (p - po).norm()) > 1e-6) continue;  // shadow
      const Eigen::Vector3d p_in_proj = rig.projector_from_left * p;
      if (p_in_proj.z() <= 0) continue;
      const Eigen::Vector2d q = rig.projector->Project(p_in_proj);
      if (!rig.projector->InImage(q)) continue;
      v.phase.at<float>(r, c) = static_cast<float>(q.x());
    }
  }
  return v;
}

}  // namespace fringe::stereo::testing
