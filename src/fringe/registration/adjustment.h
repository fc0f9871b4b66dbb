// Global marker adjustment: every marker position of the map and every view pose refined
// jointly (thesis capability 3), so that errors do not accumulate around a closed loop of views.
//
// Unknowns: world_from_sensor of each view (angle-axis + translation) and the world position of
// each marker. Residual per observation (view v saw marker k at x in its sensor frame with
// covariance C): L^T R_v^T (world_from_sensor_v * x - X_k) with L L^T = C^-1, three components
// (whitened in the sensor frame, where C is known: a triangulated centre is several times less
// certain along its viewing ray than across it). Solved with
// Ceres (sparse normal Cholesky when available, else dense QR), with a Huber loss at
// huber_sigmas so that a wrong or disturbed observation cannot pull the map. Fixed views (the
// world view) hold the gauge.
//
// Frames: sensor frames of the views, world = the fixed view's frame. Millimetres.
// Deterministic (single-threaded solve). Thread safety: reentrant.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "fringe/geometry/rigid3.h"

namespace fringe::registration {

struct MarkerSighting {
  int view = 0;
  int marker = 0;  // index into the map
  Eigen::Vector3d centre_in_sensor = Eigen::Vector3d::Zero();
  double sigma_mm = 0.05;  // > 0
  // Full covariance of centre_in_sensor (mm^2, positive definite), or zero: sigma_mm^2 / 3 in
  // every direction.
  Eigen::Matrix3d covariance_in_sensor = Eigen::Matrix3d::Zero();
};

struct AdjustmentOptions {
  double huber_sigmas = 3.0;  // robust loss scale in units of the observation sigma, > 0
  int max_iterations = 100;   // >= 1
  void Check() const;
};

enum class AdjustmentStatus { kOk, kNotConverged, kNothingToAdjust };
const char* ToString(AdjustmentStatus s);

struct AdjustmentSummary {
  AdjustmentStatus status = AdjustmentStatus::kNothingToAdjust;
  std::string message;  // Ceres' termination message when not converged
  int views = 0, markers = 0, observations = 0, iterations = 0;
  double rms_initial_mm = 0, rms_final_mm = 0;  // unweighted 3D residual RMS
  double max_final_mm = 0;
  double seconds = 0;
  bool ok() const { return status == AdjustmentStatus::kOk; }
  std::string BriefReport() const;
};

struct AdjustmentResult {
  std::vector<Rigid3d> world_from_sensor;
  std::vector<Eigen::Vector3d> markers_in_world;
  AdjustmentSummary summary;
};

// view_fixed: one flag per pose (at least one view should be fixed, else view 0 is). Throws
// fringe::Error for bad options, indices out of range or non-positive sigmas.
AdjustmentResult AdjustMarkers(const std::vector<Rigid3d>& world_from_sensor,
                               const std::vector<Eigen::Vector3d>& markers_in_world,
                               const std::vector<MarkerSighting>& sightings,
                               const std::vector<bool>& view_fixed,
                               const AdjustmentOptions& options = {});

}  // namespace fringe::registration
