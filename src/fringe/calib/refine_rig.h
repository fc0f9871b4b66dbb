// Refinement of a stereo rig from a scan's own correspondences: a Ceres
// bundle over the views' points and markers, refining the right camera's pose (and, when the
// projector is calibrated, the projector's) and optionally the cameras' focal lengths
// and k1 k2. The views' data come from pipeline/refine.h; this file is the
// problem alone (no decoding, no files).
//
// Unknowns: every phase point and every marker in its view's left camera frame (3 each, Schur
// eliminated), the rig blocks. Residuals, each divided by its noise (RigRefinementOptions):
//   - a point's left pixel (2): where it was measured, exact up to pixel_sigma_px;
//   - its phase in the right camera (1): the right camera's absolute phase map, bicubically
//     interpolated at the point's projection, minus the left phase (stereo with vertical
//     fringes: the matcher's own constraint, now with the rig free); both phases are noisy, so
//     its noise is sqrt(2) phase_sigma_px;
//   - its projector column (1, calibrated projector): the projection's column minus the phase;
//   - a marker's centres in both images (2 + 2): the only evidence of a vertical disparity when
//     the fringes are vertical.
// A phase point alone is not redundant in plain stereo (3 unknowns, 3 residuals): the markers
// and a calibrated projector carry the information; without either nothing is refined
// (status kNoEvidence).
//
// Gauge and scale: the left camera frame is the sensor frame (fixed). With one fringe direction
// the three devices see horizontal disparities; a yaw of the right camera (about the axis
// perpendicular to the baseline) shifts the right disparity almost uniformly, which is what a
// change of depth does, and a matching yaw of the projector keeps the points on their columns:
// together they bend depth (1/z' = 1/z - c, a sphere flattened or stretched along the viewing
// direction) and every observation stays consistent to first order. The data cannot tell; one
// device's orientation must hold it. So without a sphere constraint the projector's orientation
// is never refined: it holds this gauge (it is the third device of the trifocal consistency), and
// the metric scale is held by one length: the projector's distance |projector_from_left.t|
// (kProjector: the projector's pose is held, the baseline refined; the default when the projector
// is calibrated) or the baseline |right_from_left.t| (kBaseline: its direction stays free; the
// projector's translation is refined except its shift along its own columns, which vertical
// fringes do not see). Without a calibrated projector only the markers constrain the rig, and
// they leave the right camera's yaw to the same trade-off: such a refinement is refused as not
// determined unless the markers' spread in depth decides it.
//
// A certified sphere in the scan decides the bend: its surface must be round, which a bent depth
// is not. With RigRefinementOptions::sphere, every phase point the caller marked as lying on a
// sphere (RefinePhasePoint::sphere, an index into RigRefinementData::spheres; one sphere per view
// it was found in) gets one more residual, (|p - c| - r) / sphere->sigma_mm, with the centre c
// free (3 unknowns per sphere and view). The bend is then determined, so the projector's yaw
// (its rotation about its own y axis, the axis along its columns: the one rotation the bend
// trades against; its pitch and roll stay held as before) is refined too, and without a
// projector the right camera's yaw is determined by the sphere and the right phase alone (a
// phase point on the sphere is redundant: 4 residuals, 3 unknowns). The scale: kArtefact (the
// default with a sphere) holds it by the certified radius r: both translations are free (the
// projector's but for its shift along its columns); with kProjector or kBaseline a length
// holds it and r is free per sphere (the sphere then constrains the shape only, not the size).
// Which points lie on the sphere is the caller's choice (pipeline/refine.h finds the sphere
// robustly in the initial triangulation; calib does not search).
//
// A result is accepted only when the data determine it: every refined parameter's standard
// deviation (Schur complement of the points, below) must be below the options' limits, else the
// status is kNotDetermined naming the parameter, and the rig is returned unchanged. The solve is
// repeated until it settles (a round moves no parameter by more than settle_sigmas of its sigma):
// Ceres' function tolerance alone stopped a one-view bundle 10 sigmas short of its optimum. And
// it is accepted only when it gained something measurable: a change significant against its own
// uncertainty (min_change_sigmas) and residuals that improved (min_evidence_ratio); else
// kNotSignificant, the rig unchanged.
//
// Thread safety: reentrant. Deterministic (Ceres single-threaded, bundle.h).
#pragma once

#include <Eigen/Core>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fringe/calib/bundle.h"
#include "fringe/geometry/stereo_rig.h"

namespace fringe::calib {

// One measured left pixel of a view.
struct RefinePhasePoint {
  int view = 0;
  Eigen::Vector2d left_px = Eigen::Vector2d::Zero();
  double phase = 0;  // the left camera's absolute phase there, projector columns
  Eigen::Vector3d p_in_left = Eigen::Vector3d::Zero();  // triangulated by the initial rig
  int sphere = -1;  // index into RigRefinementData::spheres when it lies on one, else -1
};

// One marker seen by both cameras.
struct RefineMarker {
  int view = 0;
  Eigen::Vector2d left_px = Eigen::Vector2d::Zero(), right_px = Eigen::Vector2d::Zero();
  Eigen::Vector3d p_in_left = Eigen::Vector3d::Zero();  // triangulated by the initial rig
};

// The certified sphere of a scan: what calib needs of an artefact file's sphere (eval reads the
// file; calib sits below eval, so the pipeline converts).
struct RefineSphere {
  double diameter_mm = 0;  // certified, > 0
  // Noise of a point's radial residual, mm, > 0: the sphere's form deviation and what of the
  // surface the points do not follow (the phase residuals carry the measurement noise).
  double sigma_mm = 0.005;
};

// The sphere in one view: its centre (left camera frame) as the initial triangulation gives it.
struct RefineSphereView {
  int view = 0;
  Eigen::Vector3d centre_in_left = Eigen::Vector3d::Zero();
};

struct RigRefinementData {
  std::vector<RefinePhasePoint> points;
  std::vector<RefineMarker> markers;
  // Per view, the right camera's absolute phase (CV_32F, projector columns, NaN = invalid) on its
  // grid: the right-phase residuals. Views without one (or empty) have none.
  std::vector<cv::Mat> right_phase;
  // The certified sphere (RigRefinementOptions::sphere) where it was found: one entry per view
  // and sphere, its phase points naming it (RefinePhasePoint::sphere).
  std::vector<RefineSphereView> spheres;
};

enum class RefineScale {
  // kArtefact with a sphere constraint, else kProjector when the rig has a calibrated projector,
  // else kBaseline
  kAuto = 0,
  kBaseline = 1,   // |right_from_left.t| held
  kProjector = 2,  // the projector's pose held (needs a calibrated projector)
  kArtefact = 3,   // the certified sphere's diameter (needs RigRefinementOptions::sphere)
};
const char* ToString(RefineScale s);

struct RigRefinementOptions {
  bool intrinsics = false;  // also fx fy k1 k2 of both cameras
  RefineScale scale = RefineScale::kAuto;
  // The certified sphere's shape constraint (header); none: the rig alone as above.
  std::optional<RefineSphere> sphere;
  double pixel_sigma_px = 0.02;   // a phase point's left pixel, > 0
  double phase_sigma_px = 0.05;   // decoded phase, projector pixels, > 0
  double marker_sigma_px = 0.05;  // marker centres, pixels, > 0
  // Huber loss on every residual at this many sigmas (false matches, occlusion edges), > 0.
  double loss_sigmas = 3.0;
  // Largest standard deviations of an accepted result (larger: not determined by the data).
  double max_rotation_sigma_deg = 0.01;     // > 0
  double max_translation_sigma_mm = 0.2;    // > 0
  double max_focal_sigma_fraction = 0.005;  // of the focal length, > 0
  // Acceptance: the change must be significant against the bundle's own uncertainty (some
  // refined parameter moved by more than this many of its standard deviations), > 0 ...
  double min_change_sigmas = 3.0;
  // ... and the evidence must improve: every residual kind present ends no higher than it began
  // and one of them ends below this fraction of its initial RMS, in (0, 1].
  double min_evidence_ratio = 0.9;
  // Solve rounds: a one-view bundle stops (function tolerance) in the shallow valley where a
  // pitch of the right camera trades against its vertical shift, several of its own sigmas from
  // the optimum; the solve is restarted until a round moves every refined parameter by less
  // than settle_sigmas of its standard deviation, at most max_rounds times (else kNotDetermined).
  double settle_sigmas = 0.1;  // > 0
  int max_rounds = 10;         // >= 1
  // The cost creeps down for many iterations once the rig is found (thousands of points each
  // settling on its interpolated phase); a relative change of 1e-6 per iteration moves the rig by
  // far less than its sigma (the half-size test scan converges in ~40 iterations).
  SolveOptions solve = [] {
    SolveOptions o;
    o.function_tolerance = 1e-6;
    o.parameter_tolerance = 1e-10;
    return o;
  }();
  void Check() const;
};

enum class RefineStatus {
  kOk = 0,
  // Nothing redundant constrains the rig (no markers, no calibrated projector), or a sphere
  // constraint was asked for and no point lies on a sphere.
  kNoEvidence,
  kNotDetermined,  // the data leave a refined parameter undetermined (one flat view, ...)
  kFailed,         // the solver failed
  // The solution differs from the input rig by no more than its own uncertainty, or the
  // evidence (epipolar, right-phase, projector residuals) did not improve: nothing measurable
  // was gained, the rig is left as it was.
  kNotSignificant,
};
const char* ToString(RefineStatus s);

// One refined parameter: value before and after, its standard deviation after.
struct RefinedParameter {
  std::string name;  // "right_from_left rotation x", "right fx", ...
  std::string unit;  // "deg", "mm", "px", ""
  double before = 0, after = 0, sigma = 0;
};

struct RigRefinementSummary {
  RefineStatus status = RefineStatus::kNoEvidence;
  std::string message;
  RefineScale scale = RefineScale::kAuto;  // what held the scale (kAuto resolved)
  std::vector<std::string> refined;        // the blocks refined, in words
  std::vector<RefinedParameter> parameters;
  int points = 0, markers = 0, views = 0;
  // Residual RMS by kind, before and after (NaN without that kind): markers' epipolar distance
  // under the rig (px), right-phase and projector-column residuals of the points (projector px).
  double marker_epipolar_rms_before_px = std::numeric_limits<double>::quiet_NaN();
  double marker_epipolar_rms_after_px = std::numeric_limits<double>::quiet_NaN();
  double right_phase_rms_before_px = std::numeric_limits<double>::quiet_NaN();
  double right_phase_rms_after_px = std::numeric_limits<double>::quiet_NaN();
  double projector_rms_before_px = std::numeric_limits<double>::quiet_NaN();
  double projector_rms_after_px = std::numeric_limits<double>::quiet_NaN();
  // Rotation of the right camera (and projector) between the input and the refined rig, deg.
  double right_rotation_change_deg = 0, projector_rotation_change_deg = 0;
  double baseline_before_mm = 0, baseline_after_mm = 0;
  // The sphere constraint (RigRefinementOptions::sphere): spheres (views) and points on them;
  // the radial RMS of the points about their spheres in the bundle (mm, before: the initial
  // points about the initial centres; NaN without); and the shape of the sphere points
  // triangulated by the input rig (before) and again by the refined rig alone (after, without
  // the sphere's residuals, FitSpheroid): the mean semi-axis across and along the viewing
  // direction and their ratio (1: round). A rig refused keeps the before figures as after.
  int spheres = 0, sphere_points = 0;
  double sphere_rms_before_mm = std::numeric_limits<double>::quiet_NaN();
  double sphere_rms_after_mm = std::numeric_limits<double>::quiet_NaN();
  double sphere_axis_ratio_before = std::numeric_limits<double>::quiet_NaN();
  double sphere_axis_ratio_after = std::numeric_limits<double>::quiet_NaN();
  double sphere_radius_across_before_mm = std::numeric_limits<double>::quiet_NaN();
  double sphere_radius_across_after_mm = std::numeric_limits<double>::quiet_NaN();
  double sphere_radius_along_before_mm = std::numeric_limits<double>::quiet_NaN();
  double sphere_radius_along_after_mm = std::numeric_limits<double>::quiet_NaN();
  int solve_rounds = 0;  // Ceres solves until the rig settled (RigRefinementOptions::max_rounds)
  SolveReport solve;
  bool ok() const { return status == RefineStatus::kOk; }
  std::string BriefReport() const;
};
nlohmann::json ToJson(const RigRefinementSummary& s);

struct RigRefinement {
  StereoRig rig;  // refined when ok(), else the input rig unchanged
  RigRefinementSummary summary;
};

// A spheroid with its axis along `axis` (unit): semi-axes across (equatorial) and along it, and
// its centre; a linear least-squares fit of the quadric A (x^2 + y^2) + C z^2 + D x + E y + F z = 1
// in a frame whose z is the axis (centred on the points). What measures a sphere flattened or
// stretched along the viewing direction; ok false for fewer than 6 points or no ellipsoid.
struct SpheroidFit {
  bool ok = false;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double across_mm = 0, along_mm = 0;
  double axis_ratio() const { return along_mm / across_mm; }
};
SpheroidFit FitSpheroid(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& axis);

// Throws fringe::Error for bad options, a bad rig, kProjector without a projector, kArtefact
// without a sphere, or data naming a view without its phase map or a sphere that is not there.
RigRefinement RefineRig(const StereoRig& rig, const RigRefinementData& data,
                        const RigRefinementOptions& options = {});

}  // namespace fringe::calib
