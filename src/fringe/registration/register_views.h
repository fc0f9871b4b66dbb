// Multi-view registration (thesis capability 3): every view's cloud placed in one world frame.
//
// Stages, each reported in the summary:
//  1. Input checks per view: empty cloud, no normals, an extent that looks like metres rather
//     than millimetres (a view smaller than min_extent_mm across): the view gets a bad-input
//     status; the others go on.
//  2. World = the sensor frame of the first good view. Views with markers join the growing
//     marker map by distance invariance (marker_matching.h), in any order: each round places the
//     pending view with the most verified correspondences, until no pending view matches. A
//     view with an initial pose (e.g. fringe register --initial) is placed by it.
//  3. Views still pending are placed marker-free: every pair of usable views with at
//     least one pending view gets coarse candidates (coarse.h: Open3D's FPFH + sequential RANSAC,
//     features computed once per view), each refined by pairwise ICP and verified on its own
//     (register_views.cc, CheckPair: overlap and normal agreement within the views' noise,
//     surface_noise.h; for views with grids, the free-space check of free_space.h; no rival
//     pose about as good; no unconstrained direction); the verified pairs, with the relative
//     poses of the views placed already, form a pose graph (pose_graph.h) whose triangles that
//     do not close reject their wrong edge, and the pending views are placed along its
//     strongest edges. Never a confidently wrong pose on a symmetric or featureless scene: what
//     cannot be placed is reported as unplaced with every pair's reason, never dropped.
//  4. Global marker adjustment of the map and the marker-placed poses (adjustment.h, Ceres).
//  5. Multi-level simultaneous multi-view ICP (icp.h) over all placed views, the world view
//     fixed, each view associated with the few views it overlaps most (IcpOptions::
//     max_partners); its first threshold follows the marker alignment error (or the coarse
//     alignment's).
//
// Frames: each view's cloud and markers in its sensor frame (left camera), results as
// world_from_sensor; world = the first good view's sensor frame. Millimetres.
// Deterministic for fixed seeds except for the Open3D RANSAC step (coarse.h). Thread safety:
// reentrant; TBB inside the ICP.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "fringe/geometry/point_cloud.h"
#include "fringe/geometry/rigid3.h"
#include "fringe/registration/adjustment.h"
#include "fringe/registration/coarse.h"
#include "fringe/registration/icp.h"
#include "fringe/registration/marker_matching.h"
#include "fringe/registration/markers.h"
#include "fringe/registration/pose_graph.h"

namespace fringe::registration {

struct RegistrationView {
  std::string name;                 // e.g. the input file's stem
  PointCloud cloud;                 // sensor frame, mm, unit normals toward the sensor
  std::vector<ViewMarker> markers;  // sensor frame; empty when the view has none
  std::optional<Rigid3d> initial_world_from_sensor;
  // The organized grid `cloud` was compacted from (IndexViewGrid), when the view has one: the
  // ICP then associates projectively onto this view (icp.h).
  std::optional<ViewGrid> grid;
};

struct RegistrationOptions {
  bool use_markers = true;      // false: marker-free path for every view
  bool coarse_fallback = true;  // marker-free placement of the views the markers cannot place
  bool adjust_markers = true;   // global marker adjustment
  bool refine_icp = true;       // multi-level multi-view ICP
  double min_extent_mm = 5.0;   // smaller clouds look like metres: refused, > 0
  // ICP's first threshold: icp_threshold_factor x the worst marker alignment RMS, at least
  // icp_min_start_threshold_mm (the point spacing and noise must fit under it), > 0.
  double icp_threshold_factor = 10.0;
  double icp_min_start_threshold_mm = 1.0;
  // Marker-free placement (register_views.cc, CheckPair): a pair's candidate needs overlap >=
  // coarse_verify_min_overlap, (0, 1]; at most coarse_max_inconsistent of its close samples
  // farther than coarse_verify_tolerance_factor x the views' combined noise or with
  // disagreeing normals, [0, 1) (right pairs of the real bunny scans: 4-14 %, their
  // calibrations differ by more than their noise); at most coarse_max_free_space of its samples
  // in the other view's free space (views with grids), [0, 1) (simulated quarter-rig views:
  // right poses 0.4-1.2 %, plate-on-plate wrong ones 1.9-12 %); and every different candidate
  // pose must conflict more (inconsistent + free space), or be consistent less, by
  // coarse_min_gap, (0, 1).
  double coarse_verify_min_overlap = 0.2;
  double coarse_verify_tolerance_factor = 4.0;  // > 0
  double coarse_max_inconsistent = 0.25;
  double coarse_max_free_space = 0.015;
  double coarse_min_gap = 0.05;
  double coarse_same_pose_deg = 1.0;  // > 0
  // The pairwise ICP of the candidates samples only points whose neighbours' normals agree
  // within this (IcpOptions::sample_max_normal_spread_deg), [0, 180).
  double coarse_icp_normal_spread_deg = 10.0;
  double coarse_same_pose_mm = 1.0;  // > 0
  MarkerMatchOptions matching;
  PoseGraphOptions pose_graph;  // the marker-free path's cycle check (pose_graph.h)
  AdjustmentOptions adjustment;
  CoarseOptions coarse;
  // The threshold schedule is the one of icp_schedule.h (per level, as every caller). Directions
  // weaker than 1e-3 of the strongest stay where the markers put them: on a scene like a plate with
  // a few boxes and a ball, the data along them is biased by edge points by more than the markers'
  // error (IcpOptions' own 1e-5 is for starts with no such knowledge). Uniform sampling for the
  // same reason: normal-space samples make those directions look constrained (bench_registration
  // from the marker poses: 0.013 mm centroid error with them, 0.0027 mm without).
  // The coarse levels stop at the next level's resolution (icp_schedule.h): their last
  // iterations changed nothing the fine level kept.
  IcpOptions icp = [] {
    IcpOptions o;
    o.degeneracy_ratio = 1e-3;
    o.normal_space_sampling = false;
    o.coarse_levels_to_next_sigma = true;
    return o;
  }();
  // The refinement when some view was placed without markers (marker-free or by an initial
  // pose): nothing then knows the sliding directions better than the data, and holding them, as
  // `icp` does, keeps the pose graph's error (half rig, 8 views: 1.46 mm before the refinement
  // and after). So every direction is free, and only correspondences that fix them without bias
  // count: normal-space samples (the walls as many as the plate), smooth normals only (rims and
  // creases are smeared, differently in each view), no grazing-incidence points, none beyond the
  // target's coverage, and normals within 10 deg (45 let a wall pair with a rounded edge). None
  // is trimmed: once those are out, the largest residuals are the walls that still carry the
  // slide, which trimming would cut first and let back one iteration at a time.
  // bench_registration --scale 0.5 --no-markers --start-slide-mm 1 (the refinement alone, every
  // view slid 1 mm): 0.60 mm left with `icp`'s settings, 0.64 mm with every direction free,
  // 0.053 mm with normals within 45 deg and trimming, 0.023 mm with these; without the smooth
  // normals 1.8 mm, uniform samples 0.11 mm, no tangential test 0.040 mm. Its
  // initial_threshold_mm is the first threshold of such a refinement.
  IcpOptions marker_free_icp = [] {
    IcpOptions o;
    o.normal_space_sampling = true;
    o.sample_max_normal_spread_deg = 10;
    o.max_incidence_deg = 70;
    o.max_tangential_spacings = 2;
    o.max_normal_angle_deg = 10;
    o.trim_fraction = 1;
    o.max_iterations_per_level = 50;
    o.coarse_levels_to_next_sigma = true;
    return o;
  }();
  void Check() const;
};

enum class ViewPath { kWorld, kMarkers, kInitial, kMarkerFree, kUnplaced, kBadInput };
const char* ToString(ViewPath p);

struct ViewRegistration {
  std::string name;
  ViewPath path = ViewPath::kUnplaced;
  std::string message;  // why unplaced / bad input, or how it was placed
  Rigid3d world_from_sensor;
  Rigid3d world_from_sensor_markers;   // after marker matching (markers path)
  Rigid3d world_from_sensor_adjusted;  // after the global marker adjustment
  int markers = 0;                     // markers in the view
  int matched_markers = 0;             // correspondences with the map when it joined
  double marker_rms_mm = 0;            // of its rigid fit when it joined
  double adjusted_rms_mm = 0;          // its sightings after the global adjustment
  double overlap_fraction = 0;         // largest ICP overlap with another view
  double surface_noise_mm = 0;         // local plane-fit noise (surface_noise.h); marker-free only
  bool placed() const {
    return path == ViewPath::kWorld || path == ViewPath::kMarkers || path == ViewPath::kInitial ||
           path == ViewPath::kMarkerFree;
  }
};

// A marker of the map (world frame) and who saw it.
struct MapMarker {
  int id = 0;
  Eigen::Vector3d centre_in_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal_in_world = Eigen::Vector3d::UnitZ();
  double outer_radius_mm = 0;
  double sigma_mm = 0;
  // The centre's covariance (world frame, mm^2): the sightings' information summed, inverted.
  Eigen::Matrix3d covariance_in_world = Eigen::Matrix3d::Zero();
  struct Sighting {
    int view = 0;         // index into RegistrationResult::views
    int view_marker = 0;  // index into that view's markers
  };
  std::vector<Sighting> sightings;
};

enum class RegistrationStatus { kOk, kPartial, kFailed };
const char* ToString(RegistrationStatus s);

struct RegistrationSummary {
  RegistrationStatus status = RegistrationStatus::kFailed;
  std::string message;
  int placed = 0, unplaced = 0, bad_input = 0;
  AdjustmentSummary adjustment;
  IcpSummary icp;
  double seconds = 0;
  bool ok() const { return status == RegistrationStatus::kOk; }
  std::string BriefReport() const;
};

struct RegistrationResult {
  std::vector<ViewRegistration> views;  // one per input view, same order
  std::vector<MapMarker> map;
  RegistrationSummary summary;
};

// Throws fringe::Error only for bad options; data problems come back as per-view statuses.
RegistrationResult RegisterViews(const std::vector<RegistrationView>& views,
                                 const RegistrationOptions& options = {});

}  // namespace fringe::registration
