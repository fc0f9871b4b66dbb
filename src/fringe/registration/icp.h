// Multi-level, multi-view point-to-plane ICP with a shrinking correspondence threshold (thesis
// capability 3, refinement).
//
// All views are refined SIMULTANEOUSLY: in every iteration each free view's sample points (and
// the fixed views' too with sample_fixed_views) are associated with every other view's cloud
// (nearest neighbour, see Association below), and one linear least-squares step moves all free
// views together (point-to-plane residuals against the target's grid normals, linearised about the
// clouds' common centroid, 6 unknowns per free view). Closed loops of views therefore share
// the error instead of accumulating it; with two views, one fixed, it is ordinary pairwise ICP.
//
// Levels: the views are subsampled, coarse to fine: level l uses the first points_per_level[l]
// points of a seeded order, normal-space (Rusinkiewicz & Levoy 2001: the points binned by normal
// direction, one per bin in turn, so that on a plane-dominated scene the few walls that fix the
// sliding directions are not drowned by the plate) or uniformly random. Rejection: point-to-plane
// distance over the threshold, normals more than max_normal_angle_deg apart, then per view pair
// the worst (1 - trim_fraction) of the distances (trimmed ICP). A view pair with fewer
// correspondences than min_overlap_fraction of the source samples does not overlap and is left
// out of that iteration. The threshold schedule, the degeneracy-aware step (directions the
// surfaces do not constrain, a plane, a sphere, a cylinder, are left where the initial poses put
// them) and the convergence test are icp_schedule.h's, the one schedule every ICP of the
// project runs (AlignToMesh too).
//
// View pairs: only views whose coarse occupancy (voxels of a few thresholds, at the starting
// poses) touches are associated at all, and each view with at most max_partners of them, those
// its occupancy touches most (the pair kept when either view chooses the other). A pair of
// views that do not overlap has no correspondence to find, and a view already held by its
// max_partners largest overlaps gains little from the smaller ones: without the bound the work of
// an iteration grows with the square of the views (a ring of views around a part all see its
// plate) instead of with the views.
//
// Association: a sample is matched with the target view's point nearest to it, either exactly
// through a k-d tree over the target (geometry/point_index.h; any cloud), or projectively on the
// target's organized grid (a view that carries its grid, IcpView::grid): the sample is projected
// into the target's pixel grid with the projection fitted from the grid itself
// (geometry/grid_projection.h: no camera model needed) and the nearest of the valid points in
// the (2w + 1)^2 slots around that position is taken (w = projective_window_px). Projection
// costs a fixed few slot reads instead of a tree descent and needs no tree; it finds the nearest
// point only when that point lies inside the window, i.e. once the views are aligned to a few
// point spacings: it is used from level projective_from_level on (bench_registration measures
// both), or from the first level when the caller bounds the starting
// misalignment within the window (start_misalignment_mm). The same distance, normal and
// trimming tests follow either way.
//
// Frames: each view's cloud in its own sensor frame; poses world_from_sensor. Millimetres.
// Deterministic for a seed and independent of the thread count (parallel search, serial sums).
// Thread safety: reentrant.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "fringe/geometry/grid_projection.h"
#include "fringe/geometry/point_cloud.h"
#include "fringe/geometry/rigid3.h"
#include "fringe/registration/icp_schedule.h"

namespace fringe::registration {

// The schedule (levels, threshold, step, convergence) is icp_schedule.h's, shared with
// AlignToMesh; these are the multi-view association's own settings.
struct IcpOptions : IcpSchedule {
  double trim_fraction = 0.9;          // (0, 1]
  double max_normal_angle_deg = 45;    // (0, 180]
  double min_overlap_fraction = 0.02;  // [0, 1)
  uint64_t seed = 1;                   // subsampling order
  // Subsample in normal-space order (true) or uniformly at random (false).
  bool normal_space_sampling = true;
  // Samples are drawn only from points whose sample_spread_neighbours nearest neighbours (in
  // their own view) all have normals within this angle of theirs (deg, [0, 180); 0: every
  // point). Creases, rims and silhouettes carry normals smeared across two surfaces and
  // positions that depend on the view direction; normal-space sampling gives them the
  // intermediate-normal bins nothing else fills, and their disagreement then decides the
  // directions the walls should: the marker-free pairwise refinement of a plate scene came to
  // rest ~1.5 mm along the plate from its true pose (bench_registration --start-slide-mm 0).
  double sample_max_normal_spread_deg = 0;
  int sample_spread_neighbours = 8;  // >= 1
  // Points of a view with a grid whose normal turns more than this from the direction to the
  // sensor (the sensor frame's origin) are neither samples nor targets (deg, (0, 90]; 0: every
  // point). Walls seen at grazing incidence are measured worst, and on a plate scene they are
  // what fixes the sliding directions (bench_registration --no-markers --start-slide-mm 0, all
  // directions free: 0.080 mm with them left out beyond 70 deg, 0.086 mm with them).
  double max_incidence_deg = 0;
  // A correspondence whose target point lies farther from the sample than this many target point
  // spacings ALONG the target's tangent plane is rejected (0: never). Such a sample lies beyond
  // the target's coverage and is matched with its border point, whose plane does not continue
  // there: on curved surfaces the residual is biased and pushes the view sideways. A slid but
  // covered sample has its nearest point within about one spacing along the plane. >= 0.
  double max_tangential_spacings = 0;
  // Samples are drawn from every view (true) or from the free views only (false): a fixed
  // view's samples only repeat, in reverse, the constraints the free views' samples already put
  // on the pair; without them pairwise ICP does half the work (bunny pair: 0.22 CPU s instead
  // of 0.48, the same pose to 0.002 deg / 0.01 mm).
  bool sample_fixed_views = false;
  // Projective association (see above) on the levels from this one on, for target views with a
  // grid; earlier levels and views without a grid use the k-d tree. >= 0 (0: every level; a
  // value >= the number of levels: never).
  int projective_from_level = 1;
  int projective_window_px = 2;  // w: (2w + 1)^2 slots, >= 0
  // The largest misalignment of any point at the starting poses, when the caller knows one
  // (RegisterViews: from the marker fits), else 0. A grid view whose window of
  // projective_window_px holds every slot within this distance of its points (checked on
  // every 64th point with GridProjection::DiscOf) is associated projectively on the levels
  // before projective_from_level too and needs no k-d tree: the nearest point the tree would
  // find lies in the window anyway (a tree over all points of a view costs more than all of
  // its level-0 searches; on the 8-view scan 5 of the 8 views qualify). >= 0.
  double start_misalignment_mm = 0;
  // A grid whose projection fits its own points worse than this (px) is searched with the
  // k-d tree instead (a window that misses the sample's own slot finds a wrong neighbour), > 0.
  double max_grid_fit_error_px = 0.5;
  // The most views each view is associated with (see View pairs above), >= 0 (0: every view
  // whose occupancy touches).
  int max_partners = 8;
  void Check() const;
};

// The organized grid a view's cloud came from, for projective association: its projection,
// fitted from the grid's points (sensor frame), and the grid slot of every point of the cloud.
struct ViewGrid {
  GridProjection projection;
  std::vector<uint32_t> slot_of_point;  // one per cloud point, < width * height
};
// The grid of a view whose cloud is grid_in_sensor.Compact() (the valid slots in grid order).
ViewGrid IndexViewGrid(const OrganizedPointCloud& grid_in_sensor);

// One view: the cloud (sensor frame, unit normals; points without a finite normal are not used)
// and its starting pose. Fixed views do not move (with none fixed, view 0 fixes the gauge).
// `grid` (optional) enables projective association onto this view.
struct IcpView {
  const PointCloud* cloud = nullptr;
  const ViewGrid* grid = nullptr;
  Rigid3d world_from_sensor;
  bool fixed = false;
};

enum class IcpStatus { kOk, kNotConverged, kNoOverlap };
const char* ToString(IcpStatus s);

struct IcpSummary {
  IcpStatus status = IcpStatus::kNoOverlap;
  std::string message;
  // Unordered view pairs whose occupancy touches at the starting poses, and of those the pairs
  // associated (at most max_partners per view).
  int touching_pairs = 0, associated_pairs = 0;
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

// Throws fringe::Error for bad options, a null or empty cloud, a cloud without normals, or a
// grid whose slots do not fit the cloud or the projection's grid.
IcpResult RefineMultiView(const std::vector<IcpView>& views, const IcpOptions& options = {});

// Pairwise convenience: target fixed (view 0), source moved (view 1): the refined
// target_from_source is result.world_from_sensor[1].
IcpResult AlignPointToPlane(const PointCloud& source, const PointCloud& target,
                            const Rigid3d& target_from_source, const IcpOptions& options = {});

// How well a source cloud placed by several candidate poses agrees with a target cloud (the
// verification of marker-free placements, register_views.cc): of `samples` samples of the
// source (usable points only), normal-space (NormalSpaceOrder: the walls and objects that tell
// a slid pose from the right one count as much as a dominant plate, but so do the grazing
// edges of range scans, the noisiest points, where even the right pose disagrees) or seeded
// uniform,
// `overlap` is the fraction whose nearest target point lies within overlap_radius_mm. Of the
// samples whose nearest target point lies within close_radius_mm (<= overlap_radius_mm: where
// the target really has surface; between the two radii a sample is at the border of the
// target's coverage, where a curved surface bends away from the last target point's plane and
// says nothing), `inconsistent` is the fraction whose point-to-plane distance exceeds
// tolerance_mm or whose normals differ by more than max_normal_angle_deg, and `consistent` the
// fraction of ALL samples that pass both tests. A right pose has overlap with few inconsistent
// samples and the most consistent ones; a pose slid along a plate keeps the plate consistent
// but loses its walls and objects.
struct SurfaceAgreement {
  double overlap = 0;
  double inconsistent = 1;
  double consistent = 0;
  int in_overlap = 0;
  int close = 0;
};
std::vector<SurfaceAgreement> MeasureAgreement(const PointCloud& source, const PointCloud& target,
                                               const std::vector<Rigid3d>& target_from_source,
                                               int samples, double overlap_radius_mm,
                                               double close_radius_mm, double tolerance_mm,
                                               double max_normal_angle_deg, uint64_t seed,
                                               bool normal_space);

}  // namespace fringe::registration
