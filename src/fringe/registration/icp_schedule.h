// The one ICP schedule of the project: levels, the shrinking correspondence threshold, the
// degeneracy-aware step and the convergence test, shared by every point-to-plane ICP
// (RefineMultiView and AlignPointToPlane in icp.h, used by fringe register and the marker-free
// placement; AlignToMesh in align_to_mesh.h, used by fringe evaluate --align). The callers
// differ only in how they find correspondences (view to view through a k-d tree, cloud to mesh
// through MeshIndex) and in how many poses they move.
//
// Levels: coarse to fine, level l uses points_per_level[l] samples. The correspondence
// threshold starts at initial_threshold_mm and shrinks by the thesis' dynamic rule, MeshLab
// AlignPair's min(previous, shrink_factor x the shrink_percentile of the residuals), never below
// min_threshold_mm, once per level (the default, which every caller uses) or after every
// iteration (shrink_within_level, MeshLab's per-iteration use of the rule; for experiments:
// on bench_registration both give the same poses from the marker starts, 0.0027 mm, while on a
// view slid along a plate the per-iteration shrink cuts the wall correspondences that still
// carry the slide).
//
// Convergence of a level: the last step moved no pose by more than convergence_rotation_deg /
// convergence_translation_mm, or it was smaller than convergence_step_sigmas standard
// deviations of the estimate itself (sigma^2 H^-1, sigma the residual RMS): a fixed length
// cannot suit both 2000 samples, whose estimate is uncertain to ~1e-3 mm and whose
// correspondences still flip by that much from one iteration to the next, and 30000; a step a
// tenth of the estimate's own uncertainty changes nothing that the data can tell. With
// coarse_levels_to_next_sigma a level that is not the last stops once its step is below the
// NEXT level's standard deviation, i.e. below sqrt(points_per_level[l] / points_per_level[l + 1])
// of its own: the next level re-estimates the poses from more samples and moves them by about
// its own deviation whatever the coarse level's last digits were (RegisterViews: from the
// marker starts of the 8-view scan the first step of every level is ~2 of its sigmas and,
// the trimming re-selecting the kept pairs, each step ~0.45 of the one before, so the coarse
// levels ran 2-3 iterations more for nothing).
//
// Thread safety: free functions without shared state.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

namespace fringe::registration {

struct IcpSchedule {
  std::vector<int> points_per_level = {2000, 8000, 30000};  // samples, coarse to fine, >= 10
  int max_iterations_per_level = 15;                        // >= 1
  double initial_threshold_mm = 5.0;                        // > 0
  double min_threshold_mm = 0.05;                           // (0, initial_threshold_mm]
  double shrink_factor = 5.0;                               // > 0
  double shrink_percentile = 0.8;                           // (0, 1]
  bool shrink_within_level = false;                         // see above
  // Directions of the normal matrix with an eigenvalue below this fraction of the largest
  // (rotations scaled by the correspondences' RMS lever) are degenerate and not moved, [0, 1).
  double degeneracy_ratio = 1e-5;
  double convergence_rotation_deg = 1e-4;    // > 0
  double convergence_translation_mm = 1e-4;  // > 0
  double convergence_step_sigmas = 0.1;      // >= 0 (0: only the fixed limits)
  bool coarse_levels_to_next_sigma = false;  // see above (with convergence_step_sigmas > 0)
  // Throws fringe::Error naming `owner` and the field.
  void Check(const char* owner) const;
};

// One level's report (the schedule fills the thresholds, iterations, convergence, RMS and
// percentiles; the caller the counts).
struct IcpLevelReport {
  int level = 0;
  int points_per_view = 0;
  double threshold_start_mm = 0, threshold_end_mm = 0;
  int iterations = 0;
  bool converged = false;
  double rms_start_mm = 0, rms_end_mm = 0;  // point-to-plane RMS over kept correspondences
  int correspondences = 0;                  // at the last iteration
  int searched_pairs = 0;                   // ordered view pairs searched (last iteration)
  int overlapping_pairs = 0;                // ordered view pairs used at the last iteration
  int degenerate_directions = 0;            // unconstrained directions left unmoved (last it)
  int projective_pairs = 0;                 // view pairs associated projectively (last it)
  // The last step: largest rotation and translation of a moved pose, and its size in standard
  // deviations of the estimate (RMS over the moved directions).
  double last_step_rotation_deg = 0, last_step_translation_mm = 0, last_step_sigmas = 0;
  // The distribution at the level's last iteration: percentiles of |point-to-plane residual|
  // over the kept correspondences, and the signed residuals themselves (an even subsample of
  // at most kReportedResiduals, for histograms).
  double residual_p50_mm = 0, residual_p90_mm = 0, residual_p99_mm = 0;
  std::vector<float> residuals_mm;
};
constexpr size_t kReportedResiduals = 20000;

// What one iteration of a caller did at the given sample count and threshold.
struct IcpIteration {
  bool overlap = false;              // false: no correspondence at all; the schedule stops
  std::vector<double> residuals_mm;  // signed point-to-plane residuals of the kept pairs
  double rms_mm = 0;                 // their RMS (before the step)
  double step_rotation_deg = 0;      // largest over the moved poses
  double step_translation_mm = 0;    // largest over the moved poses, at the lever centre
  double step_sigmas = 0;            // DegeneracyAwareStep's
};

enum class IcpScheduleOutcome { kConverged, kNotConverged, kNoOverlap };

// Runs the levels: iterate(points, threshold_mm, &report) finds correspondences within the
// threshold among `points` samples, takes one step and says what it did (it may fill the
// report's counts). Appends one report per level (the level that found no overlap included).
using IcpIterateFn =
    std::function<IcpIteration(int points, double threshold_mm, IcpLevelReport* report)>;
IcpScheduleOutcome RunIcpSchedule(const IcpSchedule& schedule, const IcpIterateFn& iterate,
                                  std::vector<IcpLevelReport>* levels);

// min(threshold, shrink_factor x the shrink_percentile of |residuals|), at least
// min_threshold_mm; the threshold unchanged for no residuals.
double ShrinkThreshold(const IcpSchedule& schedule, double threshold_mm,
                       const std::vector<double>& residuals_mm);

// The Gauss-Newton step of H x = -g for 6 unknowns per pose (3 rotations, then 3
// translations, per block), degeneracy-aware (Zhang, Kaess, Singh, "On degeneracy of
// optimization-based state estimation problems", ICRA 2016): in the eigenbasis of H with the
// rotations scaled by `lever_mm` (so that all unknowns are lengths), directions whose
// eigenvalue is below degeneracy_ratio x the largest are not moved. step_sigmas: the step's
// size in standard deviations of the estimate, sqrt(x^T H x / (residual_rms^2 x moved
// directions)).
struct IcpStep {
  Eigen::VectorXd delta;
  int degenerate = 0;
  double step_sigmas = 0;
};
IcpStep DegeneracyAwareStep(const Eigen::MatrixXd& H, const Eigen::VectorXd& g, double lever_mm,
                            double degeneracy_ratio, double residual_rms_mm);

}  // namespace fringe::registration
