// Marker correspondences between a view and a marker map by distance invariance (thesis
// capability 3): a rigid motion keeps every pairwise distance, so a correct set of
// correspondences has mutually consistent distances whatever the poses.
//
// Method: every view pair (i, j) is paired with every map pair (a, b) of the same distance
// (within tolerance) in both orientations; each such seed grows greedily by the view marker and
// map marker whose distances to all members agree best, and whose normals agree after the
// member set's rigid alignment. Each grown set (>= 3) gives a rigid transform (AlignRigid,
// weighted by the markers' uncertainties); the transform is verified by moving all view markers
// onto the map (nearest map marker within tolerance, normals compatible, one to one), and then
// refit with outlier rejection on the verified set. The final fit of the winner then weighs
// every correspondence by its full covariance (R C_view R^T + C_map; Gauss-Newton from the
// closed-form fit): a triangulated centre is several times less certain along its viewing ray
// than across it, and the view's rays and the map's differ. The hypothesis verified by the most
// markers wins; when a DIFFERENT transform (a symmetric layout) is verified by nearly as many
// markers, the match is refused (kAmbiguous) rather than risk a confidently wrong one. Normals
// break the flip symmetry of planar layouts (a mirror image is no rigid motion, a flip turns
// normals over). A hypothesis of only three markers (always congruent to their mirror image; a
// chance triple of an unrelated layout agrees within the distance tolerance) must also fit within
// twice the RMS its markers' uncertainties predict.
//
// Frames: view markers in the view's sensor frame, map markers in the world frame; the result
// is world_from_sensor. Millimetres. Deterministic (no randomness). Thread safety: reentrant.
#pragma once

#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "fringe/geometry/rigid3.h"

namespace fringe::registration {

// A marker position with its normal and uncertainty, in some frame.
struct MarkerPoint {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // mm
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // unit, or zero when unknown
  double sigma_mm = 0.05;                            // 1-sigma centre uncertainty, > 0
  // Full centre covariance (mm^2) in the same frame, or zero: sigma_mm^2 / 3 in every
  // direction. Only the final rigid fit uses it (the distance tests use sigma_mm).
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
};

struct MarkerMatchOptions {
  // Pairwise distances agree within max(distance_tolerance_mm, sigma_factor * combined sigma).
  double distance_tolerance_mm = 0.3;  // > 0
  double sigma_factor = 4.0;           // >= 0
  double max_normal_angle_deg = 30;    // matched markers' normals after alignment, (0, 180]
  int min_matches = 3;                 // fewer verified correspondences: no match, >= 3
  // A different transform verified by at least (best count - ambiguity_margin) markers makes
  // the match ambiguous, >= 0.
  int ambiguity_margin = 1;
  // Transforms closer than this are the same hypothesis (rotation deg, translation mm), > 0.
  double same_pose_deg = 2.0;
  double same_pose_mm = 2.0;
  // Rigid fit outlier rejection: residuals beyond max(3 RMS, distance_tolerance_mm) dropped.
  int outlier_rounds = 3;  // >= 0
  void Check() const;
};

enum class MarkerMatchStatus {
  kOk,
  kTooFewMarkers,    // fewer than min_matches markers in the view or the map
  kNoConsistentSet,  // no set of >= min_matches mutually consistent correspondences
  kAmbiguous,        // two different transforms fit about equally well: refused
};
const char* ToString(MarkerMatchStatus s);

struct MarkerMatchResult {
  MarkerMatchStatus status = MarkerMatchStatus::kTooFewMarkers;
  std::string message;
  std::vector<std::pair<int, int>> pairs;  // (view index, map index), verified, inliers
  Rigid3d map_from_view;                   // valid when ok()
  double rms_mm = 0;                       // residual of the weighted rigid fit on `pairs`
  double max_mm = 0;
  int hypotheses = 0;       // distinct grown sets tried
  int runner_up_count = 0;  // verified markers of the best different transform (0: none)
  bool ok() const { return status == MarkerMatchStatus::kOk; }
  std::string BriefReport() const;
};

MarkerMatchResult MatchMarkers(const std::vector<MarkerPoint>& view_markers,
                               const std::vector<MarkerPoint>& map_markers,
                               const MarkerMatchOptions& options = {});

}  // namespace fringe::registration
