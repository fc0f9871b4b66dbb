// Ellipses and conics for circular calibration features.
//
// Coordinates are whatever the caller uses consistently (pixels, or undistorted normalized
// camera coordinates); a conic is the symmetric 3x3 matrix C with x^T C x = 0 for points
// x = (u, v, 1) on the curve.
//
// Algorithms:
//  - FitEllipseDirect: R. Halir, J. Flusser, "Numerically stable direct least squares fitting of
//    ellipses" (WSCG 1998), the stable form of A. Fitzgibbon et al. (PAMI 1999), on points
//    normalised to zero mean and unit RMS radius.
//  - RefineEllipse: Levenberg-Marquardt on (centre, semi-axes, angle) minimising orthogonal
//    (Euclidean) point-to-ellipse distances, the geometric fit that removes the algebraic fit's
//    curvature bias.
//  - ConcentricCentre: the image of the common centre of two concentric circles is the pole of
//    the vanishing line of their plane w.r.t. either image conic; the vanishing line is the
//    repeated line of the degenerate member C1 - lambda C2 of their pencil (the double root of
//    det(C1 - lambda C2) = 0). Equivalently it is the eigenvector of C2^-1 C1 for its simple
//    eigenvalue. Exact under any homography, whatever the radii (the ellipse centres are not).
//
// Thread safety: free functions without shared state.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

namespace fringe::calib {

struct Ellipse {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double a = 1;      // semi-major axis, >= b > 0
  double b = 1;      // semi-minor axis
  double angle = 0;  // of the major axis from +x, radians, in (-pi/2, pi/2]

  Eigen::Matrix3d Conic() const;
  double AxisRatio() const { return b / a; }
  double Area() const;
  // Point on the ellipse at parameter t (radians) and the outward unit normal there.
  Eigen::Vector2d PointAt(double t) const;
  Eigen::Vector2d NormalAt(double t) const;
  // Signed orthogonal distance (positive outside) from p to the ellipse.
  double SignedDistance(const Eigen::Vector2d& p) const;
};

// Ellipse of a conic; nullopt when the conic is not a real ellipse.
std::optional<Ellipse> EllipseFromConic(const Eigen::Matrix3d& conic);
// Centre of a central conic (where its gradient vanishes); nullopt when degenerate.
std::optional<Eigen::Vector2d> ConicCentre(const Eigen::Matrix3d& conic);

// Direct (algebraic) ellipse fit; needs >= 5 points not on a line; nullopt when the points do
// not determine an ellipse.
std::optional<Ellipse> FitEllipseDirect(const std::vector<Eigen::Vector2d>& points);

struct EllipseFitResult {
  Ellipse ellipse;
  double rms_residual = 0;  // RMS orthogonal distance of the points used, same unit as points
  double max_residual = 0;
  int num_points = 0;    // points used (after outlier removal)
  int num_outliers = 0;  // points dropped as outliers
};

struct EllipseFitOptions {
  int max_iterations = 20;         // geometric LM iterations, >= 0 (0: algebraic fit only)
  double outlier_sigma = 3.0;      // drop points beyond this many RMS residuals, > 0
  double min_outlier_dist = 0.25;  // ...but never closer than this (point units), >= 0
  int outlier_rounds = 2;          // fit / drop rounds, >= 0
  void Check() const;
};

// Algebraic fit, then geometric refinement with outlier removal. nullopt when < 5 points
// survive or the fit is not an ellipse.
std::optional<EllipseFitResult> FitEllipse(const std::vector<Eigen::Vector2d>& points,
                                           const EllipseFitOptions& options = {});

// Geometric refinement of `initial` on the points (orthogonal distances, LM).
Ellipse RefineEllipse(const std::vector<Eigen::Vector2d>& points, const Ellipse& initial,
                      int max_iterations);

// Image of the common centre of two concentric circles from their image conics (any order).
// nullopt when the pencil has no well-separated simple eigenvalue (e.g. identical conics).
std::optional<Eigen::Vector2d> ConcentricCentre(const Eigen::Matrix3d& conic1,
                                                const Eigen::Matrix3d& conic2);

// Centre of a concentric-ring feature from its outer and inner ellipses (radii ratio
// inner/outer on the object = radius_ratio): the pole-polar ConcentricCentre, accepted only when
// it agrees with an independent first-order estimate (ellipse-centre bias grows with radius^2,
// so extrapolating the two ellipse centres to radius 0) within
// max_disagreement_px + 0.5 |outer centre - inner centre|. nullopt otherwise: at very oblique
// views the pencil's eigenproblem becomes unstable before the ellipses do.
std::optional<Eigen::Vector2d> RingCentre(const Ellipse& outer, const Ellipse& inner,
                                          double radius_ratio, double max_disagreement_px = 0.15);

// Image conic of the circle (centre, radius) of the plane z = 0 under the homography
// image_from_plane (3x3, plane coordinates (x, y, 1) to homogeneous image points).
Eigen::Matrix3d ProjectCircle(const Eigen::Matrix3d& image_from_plane,
                              const Eigen::Vector2d& centre, double radius);

}  // namespace fringe::calib
