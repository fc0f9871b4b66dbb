// Multi-level, multi-view point-to-plane ICP with a shrinking correspondence threshold (thesis
// capability 3, refinement).
//
// All views are refined SIMULTANEOUSLY: in every iteration each view's sample points are
// associated with every other view's cloud (nearest neighbour in a nanoflann k-d tree built
// once per view in its sensor frame), and one linear least-squares step moves all free views
// together (point-to-plane residuals against the target's grid normals, linearised about the
// clouds' common centroid, 6 unknowns per free view). Closed loops of views therefore share
// the error instead of accumulating it; with two views, one fixed, it is ordinary pairwise ICP.
//
// Levels: the views are subsampled, coarse to fine: level l uses the first points_per_level[l]
// points of a seeded normal-space order (Rusinkiewicz & Levoy 2001: the points binned by normal
// direction, one per bin in turn), so that on a plane-dominated scene the few walls that fix the
// sliding directions are not drowned by the plate. The correspondence threshold is fixed within
// a level: initial_threshold_mm for the first (for registration: from the marker alignment
// error), and after each level min(previous, shrink_factor x the shrink_percentile of the last
// residual distances), never below min_threshold_mm: the dynamic threshold of the thesis,
// MeshLab AlignPair's rule min(previous, 5 x 80th percentile), applied per level because
// shrinking it within a level cuts the wall correspondences that still carry a slide.
// Rejection: distance over the threshold, normals more than max_normal_angle_deg apart, then
// per view pair the worst (1 - trim_fraction) of the distances (trimmed ICP). A view pair with
// fewer correspondences than min_overlap_fraction of the source samples does not overlap and is
// left out of that iteration. Iterations of a level stop when no view moves more than the
// convergence limits. Directions the surfaces do not constrain at all (a plane, a sphere, a
// cylinder) are detected in the eigenbasis of the normal matrix and left where the initial
// poses (the markers) put them.
//
// Not done: projective association on the organized grid (the k-d tree search is exact and
// costs ~1 us per point; projection would need the camera model, which fringe register's PLY
// inputs do not carry).
//
// Frames: each view's cloud in its own sensor frame; poses world_from_sensor. Millimetres.
// Deterministic for a seed and independent of the thread count (parallel search, serial sums).
// Thread safety: reentrant.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "fringe/geometry/point_cloud.h"
#include "fringe/geometry/rigid3.h"

namespace fringe::registration {

struct IcpOptions {
  std::vector<int> points_per_level = {2000, 8000, 30000};  // samples per view, coarse to fine
  int max_iterations_per_level = 15;                        // >= 1
  double initial_threshold_mm = 5.0;                        // > 0
  double min_threshold_mm = 0.05;                           // (0, initial_threshold_mm]
  double shrink_factor = 5.0;                               // > 0
  double shrink_percentile = 0.8;                           // (0, 1]
  double trim_fraction = 0.9;                               // (0, 1]
  double max_normal_angle_deg = 45;                         // (0, 180]
  double min_overlap_fraction = 0.02;                       // [0, 1)
  // Directions of the normal matrix with an eigenvalue below this fraction of the largest are
  // degenerate (the surfaces do not constrain them) and not moved, [0, 1).
  // 1e-5: a plate with a few walls constrains its sliding directions ~1e-4 as strongly as the
  // normal one; those are weak, not degenerate, and must move.
  double degeneracy_ratio = 1e-5;
  double convergence_rotation_deg = 1e-4;    // > 0
  double convergence_translation_mm = 1e-4;  // > 0
  uint64_t seed = 1;                         // subsampling order
  // Subsample in normal-space order (true) or uniformly at random (false), and shrink the
  // threshold once per level (false) or after every iteration (true, the thesis' and MeshLab's
  // schedule). The defaults recover views slid along a plate from a 2 deg / 2 mm start; marker
  // starts (RegistrationOptions) keep the uniform, per-iteration schedule, which was more
  // accurate there (demo scan, half-size rig: 0.014 mm vs 0.15 mm).
  bool normal_space_sampling = true;
  bool shrink_within_level = false;
  void Check() const;
};

// One view: the cloud (sensor frame, unit normals; points without a finite normal are not used)
// and its starting pose. Fixed views do not move (with none fixed, view 0 fixes the gauge).
struct IcpView {
  const PointCloud* cloud = nullptr;
  Rigid3d world_from_sensor;
  bool fixed = false;
};

struct IcpLevelReport {
  int level = 0;
  int points_per_view = 0;
  double threshold_start_mm = 0, threshold_end_mm = 0;
  int iterations = 0;
  bool converged = false;
  double rms_start_mm = 0, rms_end_mm = 0;  // point-to-plane RMS over kept correspondences
  int correspondences = 0;                  // at the last iteration
  int overlapping_pairs = 0;                // ordered view pairs used at the last iteration
  int degenerate_directions = 0;            // unconstrained directions left unmoved (last it)
  // The distribution at the level's last iteration: percentiles of |point-to-plane residual|
  // over the kept correspondences, and the signed residuals themselves (an even subsample of
  // at most kReportedResiduals, for histograms).
  double residual_p50_mm = 0, residual_p90_mm = 0, residual_p99_mm = 0;
  std::vector<float> residuals_mm;
};
constexpr size_t kReportedResiduals = 20000;

enum class IcpStatus { kOk, kNotConverged, kNoOverlap };
const char* ToString(IcpStatus s);

struct IcpSummary {
  IcpStatus status = IcpStatus::kNoOverlap;
  std::string message;
  std::vector<IcpLevelReport> levels;
  double seconds = 0;
  bool ok() const { return status == IcpStatus::kOk; }
  std::string BriefReport() const;
};

struct IcpResult {
  std::vector<Rigid3d> world_from_sensor;  // one per view (fixed views unchanged)
  // overlap[v][u]: fraction of view v's finest samples with a kept correspondence in view u.
  std::vector<std::vector<double>> overlap;
  IcpSummary summary;
};

// Normal-space sampling order of points with these unit normals (see above; also used by
// align_to_mesh.h): indices, one per normal bin in turn, seeded random within and across bins.
std::vector<uint32_t> NormalSpaceOrder(const std::vector<Eigen::Vector3d>& normals, uint64_t seed);

// Throws fringe::Error for bad options, a null or empty cloud, or a cloud without normals.
IcpResult RefineMultiView(const std::vector<IcpView>& views, const IcpOptions& options = {});

// Pairwise convenience: target fixed (view 0), source moved (view 1): the refined
// target_from_source is result.world_from_sensor[1].
IcpResult AlignPointToPlane(const PointCloud& source, const PointCloud& target,
                            const Rigid3d& target_from_source, const IcpOptions& options = {});

// How well a source cloud placed by several candidate poses agrees with a target cloud (the
// verification of marker-free placements, register_views.cc): of the first `samples`
// normal-space samples of the source (usable points only), `overlap` is the fraction whose
// nearest target point lies within overlap_radius_mm, and `inconsistent` the fraction of those
// whose point-to-plane distance exceeds tolerance_mm or whose normals differ by more than
// max_normal_angle_deg. A right pose has overlap with few inconsistent samples; a wrong pose
// that still lays a plate onto the plate has the walls and objects inconsistent.
struct SurfaceAgreement {
  double overlap = 0;
  double inconsistent = 1;
  int in_overlap = 0;
};
std::vector<SurfaceAgreement> MeasureAgreement(const PointCloud& source, const PointCloud& target,
                                               const std::vector<Rigid3d>& target_from_source,
                                               int samples, double overlap_radius_mm,
                                               double tolerance_mm, double max_normal_angle_deg,
                                               uint64_t seed);

}  // namespace fringe::registration
