// Pinhole camera with OpenCV-compatible lens distortion (k1 k2 p1 p2 k3).
//
// Frames and units (docs/conventions.md): the camera frame has its origin at the projection
// centre, x to the right, y down, z forward along the optical axis, in millimetres. Pixel
// coordinates have the centre of the top-left pixel at (0, 0).
//
// Model, as OpenCV's calib3d: for p_in_cam = (X, Y, Z), Z > 0,
//   x = X/Z, y = Y/Z, r^2 = x^2 + y^2, radial = 1 + k1 r^2 + k2 r^4 + k3 r^6
//   xd = x radial + 2 p1 x y + p2 (r^2 + 2 x^2)
//   yd = y radial + p1 (r^2 + 2 y^2) + 2 p2 x y
//   u = fx xd + cx,  v = fy yd + cy
// "Normalized" coordinates below are (x, y) (undistorted) unless named *_distorted.
// The same model serves the projector (an inverse camera).
//
// Thread safety: const methods are safe to call concurrently.
#pragma once

#include <Eigen/Core>
#include <array>

namespace fringe {

// The distortion model above on any scalar type T (double; ceres::Jet for the automatic
// derivatives of calibration, calib/bundle.h): the one implementation behind
// CameraModel::Distort and the cost functions, so the two cannot drift apart.
// d = {k1, k2, p1, p2, k3}; (x, y) undistorted normalized, (xd, yd) distorted normalized.
template <typename T>
void DistortNormalized(const T* d, const T& x, const T& y, T* xd, T* yd) {
  const T r2 = x * x + y * y;
  const T radial = T(1) + r2 * (d[0] + r2 * (d[1] + r2 * d[4]));
  *xd = x * radial + T(2) * d[2] * x * y + d[3] * (r2 + T(2) * x * x);
  *yd = y * radial + d[2] * (r2 + T(2) * y * y) + T(2) * d[3] * x * y;
}

struct CameraModel {
  int width = 1280;                               // image width in pixels, > 0
  int height = 1024;                              // image height in pixels, > 0
  double fx = 2500;                               // focal length in pixels, > 0
  double fy = 2500;                               // focal length in pixels, > 0
  double cx = 639.5;                              // principal point in pixels
  double cy = 511.5;                              // principal point in pixels
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;  // OpenCV distortion, dimensionless

  // The reference rig camera (../shared/SPEC.md): 1280x1024, 4.8 um pixels, 12 mm lens.
  static CameraModel ReferenceCamera();
  // The reference projector: 1280x800.
  static CameraModel ReferenceProjector();

  // Throws fringe::Error naming the field when a parameter is out of range.
  void Check() const;

  bool HasDistortion() const { return k1 != 0 || k2 != 0 || p1 != 0 || p2 != 0 || k3 != 0; }
  std::array<double, 5> Distortion() const { return {k1, k2, p1, p2, k3}; }
  void SetDistortion(const std::array<double, 5>& d);
  Eigen::Matrix3d K() const;

  // Pixel of a point in the camera frame. The point must have Z > 0 (not checked: callers
  // culling points behind the camera must test Z themselves).
  Eigen::Vector2d Project(const Eigen::Vector3d& p_in_cam) const {
    return PixelFromNormalized(
        Distort(Eigen::Vector2d(p_in_cam.x() / p_in_cam.z(), p_in_cam.y() / p_in_cam.z())));
  }
  // Undistorted normalized coordinates (x, y) of a pixel, by Newton iteration on the
  // distortion model (converges to < 1e-12 in normalized units inside the image).
  Eigen::Vector2d Unproject(const Eigen::Vector2d& pixel) const {
    return Undistort(NormalizedDistortedFromPixel(pixel));
  }
  // Unit direction, in the camera frame, of the ray through a pixel.
  Eigen::Vector3d Ray(const Eigen::Vector2d& pixel) const {
    const Eigen::Vector2d xy = Unproject(pixel);
    return Eigen::Vector3d(xy.x(), xy.y(), 1.0).normalized();
  }

  // Lens distortion on normalized coordinates and its inverse.
  Eigen::Vector2d Distort(const Eigen::Vector2d& xy) const;
  // Jacobian d(xd, yd) / d(x, y) of Distort at xy.
  Eigen::Matrix2d DistortJacobian(const Eigen::Vector2d& xy) const;
  Eigen::Vector2d Undistort(const Eigen::Vector2d& xy_distorted) const;

  Eigen::Vector2d PixelFromNormalized(const Eigen::Vector2d& xy_distorted) const {
    return {fx * xy_distorted.x() + cx, fy * xy_distorted.y() + cy};
  }
  Eigen::Vector2d NormalizedDistortedFromPixel(const Eigen::Vector2d& pixel) const {
    return {(pixel.x() - cx) / fx, (pixel.y() - cy) / fy};
  }

  // True when the pixel lies in [-0.5, width - 0.5) x [-0.5, height - 0.5) shrunk by margin_px.
  bool InImage(const Eigen::Vector2d& pixel, double margin_px = 0) const {
    return pixel.x() >= -0.5 + margin_px && pixel.y() >= -0.5 + margin_px &&
           pixel.x() < width - 0.5 - margin_px && pixel.y() < height - 0.5 - margin_px;
  }
};

bool operator==(const CameraModel& a, const CameraModel& b);

}  // namespace fringe
