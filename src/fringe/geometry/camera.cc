#include "fringe/geometry/camera.h"

#include <Eigen/LU>
#include <cmath>

#include "fringe/util/error.h"

namespace fringe {

CameraModel CameraModel::ReferenceCamera() {
  CameraModel c;
  c.width = 1280;
  c.height = 1024;
  c.fx = c.fy = 12.0 / 0.0048;  // 12 mm lens, 4.8 um pixels: 2500 px
  c.cx = 639.5 + 3.2;           // real principal points are never exactly centred
  c.cy = 511.5 - 2.7;
  c.k1 = -0.08;  // mild barrel distortion: ~3 px at the image corners
  c.k2 = 0.12;
  c.p1 = 1.0e-4;
  c.p2 = -5.0e-5;
  c.k3 = 0;
  return c;
}

CameraModel CameraModel::ReferenceProjector() {
  CameraModel p;
  p.width = 1280;
  p.height = 800;
  // Throw chosen so the projected field (~355 x 220 mm at 500 mm) covers the cameras' field of
  // view (~256 x 205 mm) over the whole depth of field.
  p.fx = p.fy = 1800;
  p.cx = 639.5;
  p.cy = 399.5;
  return p;
}

void CameraModel::Check() const {
  using util::CheckOption;
  CheckOption(width > 0, "CameraModel", "width", width, "must be > 0");
  CheckOption(height > 0, "CameraModel", "height", height, "must be > 0");
  CheckOption(fx > 0 && std::isfinite(fx), "CameraModel", "fx", fx, "must be finite and > 0");
  CheckOption(fy > 0 && std::isfinite(fy), "CameraModel", "fy", fy, "must be finite and > 0");
  CheckOption(std::isfinite(cx), "CameraModel", "cx", cx, "must be finite");
  CheckOption(std::isfinite(cy), "CameraModel", "cy", cy, "must be finite");
  const char* names[5] = {"k1", "k2", "p1", "p2", "k3"};
  const auto d = Distortion();
  for (int i = 0; i < 5; ++i) {
    CheckOption(std::isfinite(d[i]), "CameraModel", names[i], d[i], "must be finite");
  }
}

void CameraModel::SetDistortion(const std::array<double, 5>& d) {
  k1 = d[0];
  k2 = d[1];
  p1 = d[2];
  p2 = d[3];
  k3 = d[4];
}

Eigen::Matrix3d CameraModel::K() const {
  Eigen::Matrix3d k;
  k << fx, 0, cx, 0, fy, cy, 0, 0, 1;
  return k;
}

Eigen::Vector2d CameraModel::Distort(const Eigen::Vector2d& xy) const {
  const std::array<double, 5> d = Distortion();
  Eigen::Vector2d xy_distorted;
  DistortNormalized(d.data(), xy.x(), xy.y(), &xy_distorted.x(), &xy_distorted.y());
  return xy_distorted;
}

Eigen::Matrix2d CameraModel::DistortJacobian(const Eigen::Vector2d& xy) const {
  const double x = xy.x(), y = xy.y();
  const double r2 = x * x + y * y;
  const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
  const double g = 2 * k1 + r2 * (4 * k2 + 6 * k3 * r2);  // d(radial)/d(r^2) * 2
  Eigen::Matrix2d j;
  j(0, 0) = radial + g * x * x + 2 * p1 * y + 6 * p2 * x;
  j(0, 1) = g * x * y + 2 * p1 * x + 2 * p2 * y;
  j(1, 0) = g * x * y + 2 * p1 * x + 2 * p2 * y;
  j(1, 1) = radial + g * y * y + 6 * p1 * y + 2 * p2 * x;
  return j;
}

Eigen::Vector2d CameraModel::Undistort(const Eigen::Vector2d& xy_distorted) const {
  if (!HasDistortion()) return xy_distorted;
  // Newton's method: quadratic convergence where OpenCV's fixed-point iteration is linear and
  // leaves ~1e-3 px errors at the corners of strongly distorted images.
  Eigen::Vector2d xy = xy_distorted;
  double err = (Distort(xy) - xy_distorted).squaredNorm();
  for (int it = 0; it < 50 && err > 1e-30; ++it) {
    const Eigen::Vector2d step =
        DistortJacobian(xy).partialPivLu().solve(Distort(xy) - xy_distorted);
    // Backtrack when a full step overshoots (strong distortion far from the centre).
    double scale = 1.0;
    Eigen::Vector2d next = xy - step;
    double next_err = (Distort(next) - xy_distorted).squaredNorm();
    while (!(next_err < err) && scale > 1e-4) {
      scale *= 0.5;
      next = xy - scale * step;
      next_err = (Distort(next) - xy_distorted).squaredNorm();
    }
    if (!(next_err < err)) break;  // beyond the invertible region of the model
    xy = next;
    err = next_err;
  }
  return xy;
}

bool operator==(const CameraModel& a, const CameraModel& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy &&
         a.cx == b.cx && a.cy == b.cy && a.Distortion() == b.Distortion();
}

}  // namespace fringe
