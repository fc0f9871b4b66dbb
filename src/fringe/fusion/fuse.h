// Multi-view fusion: registered view clouds into one single-layer surface (thesis capability 5).
//
// The thesis' adaptive-neighbourhood mean-clustering fusion, after Zhou & Liu, "Accurate
// integration of multi-view range images using k-means clustering", Pattern Recognition 41
// (2008):
//   1. Overlap: a point is in an overlap when a point of ANOTHER view lies within its adaptive
//      radius r = spacing_factor * local spacing + registration_factor * registration residual
//      and the two normals agree within max_normal_angle_deg (so the two faces of a sharp edge,
//      or a thin wall's front and back, never merge).
//   2. Initial centres: an overlap point is a centre when it outranks every compatible point of
//      the other views within its seed radius (seed_factor * spacing + the registration term,
//      border_seed_factor * spacing near its view's border; rank = weight, then view index,
//      then point order), so each overlap region is seeded by the locally best view at that
//      view's own sampling (about one centre per spacing).
//   3. Iteration: every overlap point joins the nearest compatible centre within its radius;
//      each centre moves to the quality-weighted mean of its members ALONG ITS NORMAL (the
//      centre keeps the best view's tangential position: no lateral smearing of ribs,
//      engravings or edges, while the layers of all views collapse onto one), its normal
//      becomes the weighted mean normal; until at most max_moving_fraction of the centres
//      moved by convergence_mm or more in an iteration (converged), or max_iterations. Each
//      view's surface is evaluated on the centre's normal line (member tangent planes, members
//      beside the line weighted by a Gaussian), and views combine by weight however many members
//      each has. Where the views disagree far more than they do elsewhere (max_disagreement times
//      the median, i.e. beyond noise and registration error: an edge or a detail the normals blur),
//      the centre keeps its seed view's measurement instead of an average that would round the
//      edge.
//   Points outside overlaps pass through (see single coverage below); overlap points no centre
//   reaches are dropped (they are no centre because a better compatible point of another view
//   lies within their seed radius), so is a cluster that gathered only its own view's points
//   while a better compatible point of another view lies within its seed's radius, or while
//   its seed lies within one_view_cluster_border_px of its view's border (on the demo part
//   these one-view clusters had an RMS error of 0.17-0.3 mm: mixed pixels beside the overlap).
//   Weight of a point: cos^2 of its viewing angle (normal vs the direction to its sensor) * B^2 /
//   (B^2 + B0^2) with B its fringe modulation (quality) * 1 / (1 + (residual / residual0)^2) with
//   its reprojection residual * a border ramp
//   ((b + 1) / (border_ramp_px + 1))^2, b its grid distance to the nearest invalid slot (as
//   Curless & Levoy, SIGGRAPH 1996, and Turk & Levoy, SIGGRAPH 1994, weigh range-image borders:
//   the pixels beside a silhouette or a decoding hole mix two surfaces' phases; measured on the
//   simulated demo part, the points within 2 px of a border carry ~90 % of the squared error of
//   the points outside overlaps, bench_fusion --diagnose).
//   Single coverage: a point outside the overlaps that lies within border_trim_px of its view's
//   border AND has a point of another view with a larger weight within its radius (whatever
//   that point's normal: a mixed pixel's normal is as wrong as its position) is absorbed — a
//   better measurement of the place exists, the mixed pixel must not survive as its own point.
//   The other single-coverage points within border_trim_px of an invalid slot are trimmed: on
//   the demo part their RMS error is 10-15 times that of the points 6 px or more inside the
//   border (bench_fusion --diagnose), the place they claim to measure is measured by their inner
//   neighbours, and the frame edge is no border (a view of a flat field that fills the frame
//   loses nothing). Every other single-coverage point passes through, averaged along its normal
//   only with its own view's compatible grid neighbours (smooth_radius_px; 0: unchanged). The
//   summary counts absorbed and trimmed points; border_trim_px = 0 keeps them all.
//
// Neighbour search through the organized grids: a point's neighbours in another view lie in a
// small pixel window around its projection into that view's grid (the projection is fitted to
// the grid's own points, geometry/grid_projection.h: a camera's pixel grid, with its
// distortion; the window is widened by the fit's largest error, so no neighbour within the
// radius is missed). The cost per point is a fixed number of slot reads per view instead of a
// k-d tree descent over all points; the work runs in parallel over blocks of points, view by
// view (a block's windows stay in the cache), and a point outranked within its seed radius
// stops searching: a first pass reads only the seed radius' windows (most points settle there),
// and a view none of whose points within reach can outrank a point (per tile, their largest
// weight) is skipped where it could add nothing. The candidate centres of a point are found in
// its OWN view's grid: every seed is projected once into every view's grid (a bucket per slot),
// so a point reads one window instead of one per view, from its centre outwards, shrinking to
// the k-th nearest seed found. These shortcuts are exact: the output is that of reading every
// window whole (bench_fusion's fused_digest compares the output).
// Clustering iterations only revisit what changed: a point's assignment when one of its
// candidate centres moved, a centre when its membership changed or it moved; a centre whose
// update is below convergence_mm with unchanged members settles.
//
// Frames and units: each view's cloud is in its sensor frame, world_from_sensor places it; the
// output is in the world frame; millimetres.
// Determinism: every per-point decision depends only on the input, sums are taken in a fixed
// order: results do not depend on the number of threads (TBB inside).
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "fringe/geometry/point_cloud.h"
#include "fringe/geometry/rigid3.h"

namespace fringe::fusion {

// One view: an organized cloud (grid of the left camera, sensor frame, with normals; quality =
// modulation, intensity = texture and residual_px are used when present) and its pose.
struct FusionView {
  std::string name;
  OrganizedPointCloud cloud;
  Rigid3d world_from_sensor;
};

struct FusionOptions {
  // Overlap radius = spacing_factor * local spacing + registration_factor * registration_rms_mm.
  // 3 rather than 2: more members per cluster (about three points per view) and border points
  // reach a better point of another view (with border_seed_factor 3); on the demo part 0.0257
  // instead of 0.0275 mm fused RMS, for ~25 % more fusion CPU.
  double spacing_factor = 3.0;  // (0, 20]
  // Seed radius = seed_factor * local spacing + the registration term: the best point within
  // it becomes a centre. 1 covers the farthest place from a grid point (0.71 spacing), (0, 20].
  double seed_factor = 1.0;
  // Points closer than border_seed_px to their view's border (see border_ramp_px) take the seed
  // radius max(seed_factor, border_seed_factor) * spacing + the registration term: a better
  // compatible point of another view that near keeps them from seeding a centre (they join its
  // cluster or, beyond every centre's reach, are dropped as unassigned). Border points are
  // the fused cloud's worst (mixed pixels, grazing angles: on the demo part, with spacing_factor
  // 2 and 2 here, 0.0275 mm fused RMS against 0.0315 mm with the plain seed radius), while
  // a wider seed radius everywhere lets clusters reach across edges. Beyond spacing_factor it
  // changes nothing (the search sees no farther). (0, 20]; border_seed_px 0: off, [0, 100].
  double border_seed_factor = 3.0;
  int border_seed_px = 3;
  double registration_rms_mm = 0.02;  // registration residual (e.g. ICP RMS), mm, >= 0
  double registration_factor = 3.0;   // >= 0
  double max_normal_angle_deg = 30;   // normal compatibility, (0, 90)
  // Members of a cluster weigh by exp(-l^2 / (2 (lateral_sigma * spacing)^2)) with l their
  // distance beside the centre's normal line, (0, 10].
  double lateral_sigma = 0.5;
  // A cluster whose views' surfaces differ by more than max_disagreement times the median
  // difference over all clusters keeps its seed view's point (edges, fine detail), > 1.
  double max_disagreement = 4;
  int max_iterations = 10;       // clustering iterations, [1, 100]
  double convergence_mm = 1e-3;  // a centre moving less has settled, > 0
  // Converged when at most this fraction of the centres still moves (>= convergence_mm) in an
  // iteration, [0, 1); 0: every centre must settle.
  double max_moving_fraction = 1e-3;
  double modulation_half_dn = 10;  // B0 of the modulation weight, DN, > 0
  double residual_half_px = 0.5;   // residual0 of the residual weight, px, > 0
  double min_cos_view = 0.1;       // viewing-angle cosine floor of the weight, (0, 1]
  // Border ramp of the weight (see above), px, [0, 100]; 0: no ramp.
  int border_ramp_px = 3;
  // Single-coverage points closer than this to an invalid slot of their view are absorbed by
  // a better point of another view within their radius, else trimmed, px, [0, 100]; 0: never.
  int border_trim_px = 3;
  // A cluster that gathered only its own view's points although its seed has a compatible point
  // of another view within its radius is dropped when its seed lies closer than this to its
  // view's border (mixed pixels beside the overlap; that point's cluster represents the place),
  // px, [0, 100]; 0: only those whose seed that point outranks. Farther inside, such clusters
  // are the view's own sampling between the other view's centres (a sphere seen from 6 views
  // loses 40 % of its fused points without them).
  int one_view_cluster_border_px = 6;
  // Passed-through (single-coverage) points are averaged along their normal with their own
  // view's compatible grid neighbours within this many pixels (see fuse.cc,
  // SingleCoverageOffsets), [0, 10]; 0: passed through unchanged.
  int smooth_radius_px = 1;
  // Invalid regions smaller than this (decoding dropouts inside a surface) make no border, >= 1.
  int min_border_hole_px = 16;
  // A view whose points project to their grid slots with a larger error is refused (kBadView:
  // not a camera's pixel grid, the neighbour search needs one), px, > 0.
  double max_fit_error_px = 4;
  // Views whose median point spacings differ by more than this factor are taken to be in
  // different units (metres vs millimetres) and refused, > 1.
  double max_spacing_ratio = 20;

  void Check() const;
};

enum class FusionStatus {
  kOk = 0,
  kNoOverlap,       // no view overlaps another: every point passed through (output valid)
  kEmptyInput,      // no views, or no valid point in any view
  kMissingNormals,  // a view without normals (fusion needs them for compatibility and weights)
  kUnitsMismatch,   // views' point spacings differ as metres and millimetres would
  kBadView,         // grid and attribute sizes disagree, a non-finite pose, or not a camera's grid
};
const char* ToString(FusionStatus s);

struct FusionSummary {
  FusionStatus status = FusionStatus::kOk;
  std::string message;
  int views = 0;
  int64_t input_points = 0;
  int64_t overlap_points = 0;  // points with a compatible neighbour from another view
  int64_t clusters = 0;        // centres (fused points replacing the overlap points)
  int64_t passed_through = 0;  // non-overlap points, unchanged
  // Overlap points no centre reached: dropped, a better compatible point of another view lies
  // within their seed radius (that is why they are no centre).
  int64_t unassigned = 0;
  int64_t absorbed = 0;  // single-coverage border points with a better point of another view
  int64_t trimmed = 0;   // single-coverage border points without one (mixed pixels), dropped
  // Clusters of one view's points whose seed a better compatible point of another view within
  // its radius outranks: dropped (that point's cluster represents the place).
  int64_t absorbed_clusters = 0;
  int64_t disagreeing_clusters = 0;  // kept their seed view's point (last iteration)
  int64_t fused_points = 0;          // output size
  int iterations = 0;
  bool converged = false;        // see FusionOptions::max_moving_fraction
  int64_t moving_centres = 0;    // centres that moved >= convergence_mm in the last iteration
  double last_max_shift_mm = 0;  // largest centre move of the last iteration
  double median_spacing_mm = 0;  // over all views
  // Depth noise of one point along its normal, estimated from the single-coverage points'
  // grid neighbours (0 when not smoothed), mm.
  double single_coverage_noise_mm = 0;
  double max_fit_error_px = 0;  // largest error of the grids' fitted projections
  double time_s = 0;
  // Wall time of the stages (sum ~ time_s): views checked and points gathered with weights and
  // radii; overlap and seeds; candidate centres; clustering iterations; output.
  double prepare_s = 0, overlap_s = 0, candidates_s = 0, cluster_s = 0, output_s = 0;
  // True when `fused` holds the result (kOk or kNoOverlap).
  bool has_output() const {
    return status == FusionStatus::kOk || status == FusionStatus::kNoOverlap;
  }
  std::string BriefReport() const;
};
// As `fringe fuse --json` prints it (the "fusion" object).
nlohmann::json ToJson(const FusionSummary& s);

struct FusionResult {
  // World frame, mm: normals, intensity (texture) also as grey colours, quality (weighted mean
  // modulation). Centres first (in the order of their seed points), then the passed-through
  // points in view and grid order.
  PointCloud fused;
  std::vector<uint16_t> support;  // per fused point: the number of views in its cluster (1 = one)
  // Per fused point: the index (in the views given) of the view it came from: a centre's seed
  // view (the locally best view of its cluster), a passed-through point's own view.
  std::vector<uint16_t> view;
  // Per view, per grid slot: 1 where the point was in an overlap (for evaluation).
  std::vector<std::vector<uint8_t>> overlap;
  FusionSummary summary;
};

// Per grid slot: the city-block distance in grid steps to the nearest invalid slot of the grid
// in an invalid region (8-connected) of at least min_hole_px slots (0 beside one; smaller holes
// are decoding dropouts inside a surface, no border; slots beyond the frame do not count: the
// frame edge is no measurement border), capped at 65535; 0 for invalid slots.
std::vector<uint16_t> BorderDistancePx(const OrganizedPointCloud& grid, int min_hole_px);

// Fuses the views. Bad options throw fringe::Error; bad data come back as a status.
FusionResult FuseViews(const std::vector<FusionView>& views, const FusionOptions& options = {});

}  // namespace fringe::fusion
