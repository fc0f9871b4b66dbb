// Acceptance figures of VDI/VDE 2634 Part 2 ("Optical 3D measuring systems - Optical systems
// based on area scanning", 2012) computed from measured point clouds:
//   PF  probing error, form: range (max - min) of the radial residuals to the least-squares
//       sphere with free radius;
//   PS  probing error, size: fitted minus calibrated diameter (only when a calibrated diameter
//       is given; without one the form figures and the fitted diameter are still measured);
//   SD  sphere-spacing error: distance of the two fitted sphere centres (free radius) of a ball
//       bar minus the calibrated distance;
//   F   flatness measurement error: range of the signed distances to the least-squares plane.
// The standard allows up to 0.3 % of the points to be left out as outliers; we leave out the
// floor(fraction * n) points whose removal shrinks the residual range most (from either end),
// refit on the rest, and report how many were left out.
//
// The artefact's points are found in the cloud by RANSAC (seeded) with the calibrated diameter
// (spheres; without one, with a free radius: see VdiOptions::min_cap_half_angle_deg) or as the
// largest plane, then refined by least squares on the points within
// inlier_band_mm; the band is wide compared with the measurement noise so that it does not cut
// the residual distribution (which would understate PF and F).
//
// Units: millimetres; clouds in any frame. Thread safety: pure functions.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "fringe/geometry/point_cloud.h"

namespace fringe::eval {

struct SphereFit {
  bool ok = false;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius_mm = 0;
  double rms_mm = 0;  // RMS of the radial residuals
  int iterations = 0;
};
// Least-squares sphere with free radius (algebraic fit, then Gauss-Newton on the geometric
// distances). Needs >= 4 points not on one plane.
SphereFit FitSphere(const std::vector<Eigen::Vector3d>& points);

struct PlaneFit {
  bool ok = false;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  double rms_mm = 0;
};
// Total least-squares plane (PCA). Needs >= 3 points not on one line.
PlaneFit FitPlane(const std::vector<Eigen::Vector3d>& points);

// Indices to KEEP after leaving out floor(fraction * n) residuals so that the range of the kept
// ones is smallest (removing from the low end, the high end or both).
std::vector<size_t> KeepAfterDiscard(const std::vector<double>& residuals, double fraction);

struct VdiOptions {
  // Fraction of points that may be left out, [0, 0.003] (the standard's 0.3 %).
  double discard_fraction = 0.003;
  // Half width of the band around the artefact's surface whose points belong to it, mm, > 0.
  double inlier_band_mm = 0.3;
  // RANSAC for finding the artefact: iterations (>= 1), seed, and at most this many points
  // scored per hypothesis (a seeded subsample), >= 100.
  int ransac_iterations = 400;
  uint64_t seed = 1;
  int ransac_sample_points = 20000;
  // A sphere hypothesis is rejected when its radius differs from the calibrated one by more
  // than this fraction, (0, 1).
  double radius_tolerance = 0.1;
  // Fewest points an artefact must have, >= 10.
  int min_points = 100;
  // Spheres searched without a calibrated diameter (free radius): a hypothesis must be seen over
  // a cap of at least this half angle (degrees, (0, 90)), measured from its inliers' mean
  // direction from the centre. A patch of a plane fits a large sphere within the band over a
  // small cap only, so this keeps the background from being taken for the artefact (and a
  // diameter from a smaller cap would be ill-conditioned anyway).
  double min_cap_half_angle_deg = 25;
  // Largest diameter a free-radius search accepts, mm; 0 = the cloud's bounding-box diagonal.
  double max_diameter_mm = 0;

  void Check() const;
};

enum class VdiStatus { kOk = 0, kTooFewPoints, kNotFound };
const char* ToString(VdiStatus s);

struct SphereResult {
  VdiStatus status = VdiStatus::kNotFound;
  std::string message;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double diameter_mm = 0;             // fitted
  double calibrated_diameter_mm = 0;  // given; 0 = none (then PS is not measured)
  double PF_mm = 0;                   // form error (range of radial residuals)
  double PS_mm = 0;                   // fitted minus calibrated diameter (0 without one)
  double rms_mm = 0;
  int points = 0;     // used (after the discard)
  int discarded = 0;  // left out by the 0.3 % allowance
  bool ok() const { return status == VdiStatus::kOk; }
  bool has_size_error() const { return calibrated_diameter_mm > 0; }  // PS measured
  std::string BriefReport() const;
};

// The spheres of a ball bar are labelled by position, not by which one the search found first:
// sphere_a is the one with the smaller coordinate along the cloud-frame axis (x, y or z) on
// which the two centres differ most, so the labels stay the same between runs, point orders
// and seeds.
struct BallBarResult {
  VdiStatus status = VdiStatus::kNotFound;
  std::string message;
  SphereResult sphere_a, sphere_b;
  double distance_mm = 0;  // fitted centre distance
  double SD_mm = 0;        // minus the calibrated distance
  bool ok() const { return status == VdiStatus::kOk; }
  std::string BriefReport() const;
};

struct PlaneResult {
  VdiStatus status = VdiStatus::kNotFound;
  std::string message;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double F_mm = 0;  // range of signed distances
  double rms_mm = 0;
  int points = 0;
  int discarded = 0;
  bool ok() const { return status == VdiStatus::kOk; }
  std::string BriefReport() const;
};

// PF/PS of a sphere of calibrated diameter found in the cloud (the one with most inliers).
// diameter_mm <= 0: no calibrated diameter; the sphere is searched with a free radius and the
// result has PF, RMS and the fitted diameter but no PS.
SphereResult EvaluateSphere(const PointCloud& cloud, double diameter_mm,
                            const VdiOptions& options = {});
// SD of a ball bar: two spheres of the calibrated diameter, centres calibrated_distance_mm apart.
// diameter_mm <= 0: the first sphere is searched with a free radius and the second with the
// first one's fitted diameter (no PS for either).
BallBarResult EvaluateBallBar(const PointCloud& cloud, double diameter_mm,
                              double calibrated_distance_mm, const VdiOptions& options = {});
// F of the largest plane in the cloud.
PlaneResult EvaluatePlane(const PointCloud& cloud, const VdiOptions& options = {});

// The results as `fringe evaluate --json` prints them (figures only when the status is ok).
nlohmann::json ToJson(const SphereResult& r);
nlohmann::json ToJson(const BallBarResult& r);
nlohmann::json ToJson(const PlaneResult& r);

// Form and size from points already known to belong to the sphere (no search, no band): the
// figures "with true correspondences" in benchmarks. diameter_mm <= 0: no PS.
SphereResult SphereFigures(const std::vector<Eigen::Vector3d>& points, double diameter_mm,
                           double discard_fraction = 0.003);
PlaneResult PlaneFigures(const std::vector<Eigen::Vector3d>& points,
                         double discard_fraction = 0.003);

}  // namespace fringe::eval
