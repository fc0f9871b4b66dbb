// The projection of an organized cloud's own pixel grid, fitted from its points.
//
// An organized cloud from a camera (a reconstructed view) carries its camera implicitly: point
// (c, r) of the grid lies on the ray of pixel (c, r). GridProjection recovers that map from the
// points alone — column and row as cubic polynomials of the normalized coordinates x/z, y/z in
// the cloud's (sensor) frame, i.e. a pinhole with the radial and tangential distortion of the
// camera that measured it — so that a consumer without the calibration (fusion's neighbour
// search, projective ICP association) can find the slot a point falls on, or the pixel window
// that holds every slot within a radius of a point. The fit's largest error over all the grid's
// points is kept: windows widened by it miss no slot.
//
// Frames and units: points in the grid's sensor frame, millimetres; pixels with the centre of
// slot (c, r) at (c, r) (as CameraModel).
// Thread safety: a fitted GridProjection is immutable; its const methods may run concurrently.
#pragma once

#include <Eigen/Core>
#include <limits>

#include "fringe/geometry/point_cloud.h"

namespace fringe {

class GridProjection {
 public:
  static constexpr int kMonomials = 10;  // cubic in (x/z, y/z)
  using Coefficients = Eigen::Matrix<float, kMonomials, 1>;

  // Fits the projection of `grid_in_sensor` from its valid points with z > 0 (a subsample of at
  // most 40000 for the fit; the error is measured over every one). Needs at least 100 points:
  // with fewer, fitted() is false and fit_error_px() NaN; a fit without a finite solution is
  // not fitted and has an infinite error. A grid that is no camera's (e.g. all points on one
  // ray) shows as a large error: consumers compare fit_error_px() with their tolerance.
  static GridProjection Fit(const OrganizedPointCloud& grid_in_sensor);

  bool fitted() const { return fitted_; }
  // Largest distance of a valid point's projection from its slot, px (see Fit).
  double fit_error_px() const { return fit_error_px_; }
  int width() const { return width_; }
  int height() const { return height_; }

  // Fractional grid position (column, row) of a point in the sensor frame; false when not
  // fitted, p is not in front of the sensor (z <= 0) or the result is not finite. The position
  // may lie outside the grid.
  bool Project(const Eigen::Vector3f& p_in_sensor, Eigen::Vector2f* col_row) const;

  // A disc of the grid holding the slot of every point within radius_mm of p (centre col/row
  // and radius, px: the projection's local scale bound plus the fit error).
  struct Disc {
    float col = 0, row = 0, radius_px = 0;
  };
  // False when not fitted, when the sphere around p reaches behind the sensor (z <= radius_mm)
  // or the result is not finite.
  bool DiscOf(const Eigen::Vector3f& p_in_sensor, float radius_mm, Disc* disc) const;

  // DiscOf's bound at p for every radius at once (a search whose radius shrinks as it finds
  // points, e.g. the k nearest): the disc of radius R (0 <= R < z) is centred on (col, row) with
  // radius RadiusPx(R), the same value DiscOf gives.
  struct Bound {
    float col = 0, row = 0, scale = 0, norm = 0, z = 0, fit_error_px = 0;
    float RadiusPx(float radius_mm) const {
      return scale * (radius_mm * norm / (z - radius_mm)) + fit_error_px;
    }
  };
  // False when not fitted, p is not in front of the sensor (z <= 0) or the result is not finite.
  bool BoundAt(const Eigen::Vector3f& p_in_sensor, Bound* bound) const;

 private:
  int width_ = 0, height_ = 0;
  Coefficients col_poly_ = Coefficients::Zero(), row_poly_ = Coefficients::Zero();
  double fit_error_px_ = std::numeric_limits<double>::quiet_NaN();
  bool fitted_ = false;
};

}  // namespace fringe
