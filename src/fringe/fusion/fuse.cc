#include "fringe/fusion/fuse.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <string>

#include "fringe/geometry/grid_projection.h"
#include "fringe/util/error.h"
#include "fringe/util/timer.h"

namespace fringe::fusion {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int32_t kNone = -1;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// All valid points of all views in the world frame, float to halve the memory (PLY output is
// float anyway; 3e-5 mm resolution at 300 mm).
struct Points {
  std::vector<Eigen::Vector3f> pos, nrm;
  std::vector<float> weight, spacing_mm, radius_mm, seed_radius_mm, intensity, quality;
  std::vector<uint16_t> view;
  std::vector<uint32_t> grid;    // slot in the view's grid
  std::vector<uint16_t> border;  // grid distance to the view's border, px
  std::vector<uint8_t> usable;   // finite normal: takes part in the fusion
  size_t size() const { return pos.size(); }
};

// Neighbour search through the organized grids. Every view is a camera's pixel grid, so the
// points of a view within a radius of a point p lie in a small pixel window around p's
// projection into that view: a fixed cost per view instead of a tree descent over all points.
// The projection is fitted to the grid itself (GridProjection); its largest error over the
// grid's points widens every window, so a window holds every point of the view within the
// radius. A view whose grid has too few points for the fit is searched point by point.
struct ViewGrid {
  int width = 0, height = 0;
  std::vector<int32_t> point;  // per slot: the usable point (index into Points) or kNone
  // Per slot: the usable point's world position (NaN where none: the distance tests read one
  // contiguous array).
  std::vector<Eigen::Vector3f> pos;
  // Per slot: the usable point's normal and weight (read beside pos for every neighbour found:
  // slot order keeps them as local as the positions, no indirection through `point`).
  std::vector<Eigen::Vector3f> nrm;
  std::vector<float> weight;
  std::vector<uint32_t> usable_slots;  // slots holding a usable point (point-by-point search)
  // Per tile of kTile x kTile slots: the range of the usable points' depths (z in the sensor
  // frame, from `pos`; +inf / -inf for a tile without one). A point p has no neighbour within R
  // in a tile whose range does not come within R of p's depth (|q - p| >= |z_q - z_p|): a disc
  // lying on an empty region or on another surface of the view is not read slot by slot (a
  // third of the overlap search's discs on the demo part found no point at all).
  static constexpr int kTile = 8;
  int tiles_w = 0, tiles_h = 0;
  std::vector<float> tile_zmin, tile_zmax;
  // Per tile: the largest weight of its usable points (-inf without one): a point no point of
  // the tiles within its reach can outrank needs no slot of them read to find an outranking one.
  std::vector<float> tile_wmax;
  Eigen::Matrix3f sensor_from_world_r = Eigen::Matrix3f::Identity();
  Eigen::Vector3f sensor_from_world_t = Eigen::Vector3f::Zero();
  Eigen::Vector3f origin_in_world = Eigen::Vector3f::Zero();  // the sensor's origin
  GridProjection projection;
  bool fitted = false;
};

// The pixel disc of `grid` that holds every slot whose point can lie within radius_mm of p;
// false when there is none (p behind the camera). depth: p's z in the grid's sensor frame.
bool DiscOf(const ViewGrid& grid, const Eigen::Vector3f& p_in_world, float radius_mm,
            GridProjection::Disc* d, float* depth = nullptr) {
  const Eigen::Vector3f x = grid.sensor_from_world_r * p_in_world + grid.sensor_from_world_t;
  if (depth != nullptr) *depth = x.z();
  return grid.projection.DiscOf(x, radius_mm, d);
}

// Depth slack of the tile test: the tiles' depths and p's are computed in float from float
// world positions (rounding ~1e-7 relative); 1e-3 mm + 1e-5 relative is far above that.
float DepthSlack(float depth) { return 1e-3f + 1e-5f * std::abs(depth); }

// The tiles' depth ranges of a grid (ViewGrid::tile_zmin / tile_zmax) from its positions.
void FillTileDepths(ViewGrid* g) {
  constexpr int t = ViewGrid::kTile;
  g->tiles_w = (g->width + t - 1) / t;
  g->tiles_h = (g->height + t - 1) / t;
  const size_t n = static_cast<size_t>(g->tiles_w) * static_cast<size_t>(g->tiles_h);
  g->tile_zmin.assign(n, std::numeric_limits<float>::infinity());
  g->tile_zmax.assign(n, -std::numeric_limits<float>::infinity());
  g->tile_wmax.assign(n, -std::numeric_limits<float>::infinity());
  for (uint32_t slot : g->usable_slots) {
    const int c = static_cast<int>(slot % static_cast<uint32_t>(g->width));
    const int r = static_cast<int>(slot / static_cast<uint32_t>(g->width));
    const size_t k = static_cast<size_t>(r / t) * static_cast<size_t>(g->tiles_w) + c / t;
    const float z = g->sensor_from_world_r.row(2).dot(g->pos[slot]) + g->sensor_from_world_t.z();
    g->tile_zmin[k] = std::min(g->tile_zmin[k], z);
    g->tile_zmax[k] = std::max(g->tile_zmax[k], z);
    g->tile_wmax[k] = std::max(g->tile_wmax[k], g->weight[slot]);
  }
}

// The tile of a grid slot.
size_t TileOf(const ViewGrid& g, uint32_t slot) {
  const uint32_t w = static_cast<uint32_t>(g.width);
  return static_cast<size_t>(slot / w / ViewGrid::kTile) * static_cast<size_t>(g.tiles_w) +
         slot % w / ViewGrid::kTile;
}

// A pixel bound clamped to [-1, n] in float before the conversion (a disc far outside the frame
// must not overflow the int).
int Clamped(float x, int n) { return static_cast<int>(std::clamp(x, -1.f, static_cast<float>(n))); }

// Slot rows [r0, r1] x columns [c0, c1] of a grid, clipped to its frame; empty when a window
// lies beside the frame.
struct SlotWindow {
  int r0 = 0, r1 = -1, c0 = 0, c1 = -1;
  bool empty() const { return r0 > r1 || c0 > c1; }
};

// The slots whose centres lie in the square of half-width radius_px around (row, col).
SlotWindow WindowAround(const ViewGrid& g, float row, float col, float radius_px) {
  return {std::max(0, Clamped(std::ceil(row - radius_px), g.height)),
          std::min(g.height - 1, Clamped(std::floor(row + radius_px), g.height)),
          std::max(0, Clamped(std::ceil(col - radius_px), g.width)),
          std::min(g.width - 1, Clamped(std::floor(col + radius_px), g.width))};
}

// True when a tile of the grid overlapping the (non-empty) window holds a depth within
// radius_mm (+ slack) of `depth`: only then can a point there lie within radius_mm.
bool AnyTileNear(const ViewGrid& g, const SlotWindow& w, float depth, float radius_mm) {
  constexpr int t = ViewGrid::kTile;
  const float lo = depth - radius_mm - DepthSlack(depth),
              hi = depth + radius_mm + DepthSlack(depth);
  for (int tr = w.r0 / t; tr <= w.r1 / t; ++tr) {
    const size_t row = static_cast<size_t>(tr) * static_cast<size_t>(g.tiles_w);
    for (int tc = w.c0 / t; tc <= w.c1 / t; ++tc) {
      if (g.tile_zmin[row + tc] <= hi && g.tile_zmax[row + tc] >= lo) return true;
    }
  }
  return false;
}

// The largest weight of the grid's points in the tiles overlapping the (non-empty) window that
// hold a depth within radius_mm (+ slack) of `depth` (-inf when none does).
float MaxWeightNear(const ViewGrid& g, const SlotWindow& w, float depth, float radius_mm) {
  constexpr int t = ViewGrid::kTile;
  const float lo = depth - radius_mm - DepthSlack(depth),
              hi = depth + radius_mm + DepthSlack(depth);
  float best = -std::numeric_limits<float>::infinity();
  for (int tr = w.r0 / t; tr <= w.r1 / t; ++tr) {
    const size_t row = static_cast<size_t>(tr) * static_cast<size_t>(g.tiles_w);
    for (int tc = w.c0 / t; tc <= w.c1 / t; ++tc) {
      if (g.tile_zmin[row + tc] <= hi && g.tile_zmax[row + tc] >= lo) {
        best = std::max(best, g.tile_wmax[row + tc]);
      }
    }
  }
  return best;
}

// Calls f(slot, squared distance) for every slot of the grid in the disc around p that `keep`
// accepts and whose point lies within radius_mm of p, row by row (a deterministic order), until
// f returns false.
template <class Keep, class F>
void ForEachNear(const ViewGrid& grid, const Eigen::Vector3f& p_in_world, float radius_mm,
                 Keep&& keep, F&& f) {
  const float r_sq = radius_mm * radius_mm;
  if (!grid.fitted) {
    for (uint32_t s : grid.usable_slots) {
      if (!keep(s)) continue;
      const float dist_sq = (grid.pos[s] - p_in_world).squaredNorm();
      if (dist_sq <= r_sq && !f(s, dist_sq)) return;
    }
    return;
  }
  GridProjection::Disc d;
  float depth = 0;
  if (!DiscOf(grid, p_in_world, radius_mm, &d, &depth)) return;
  const SlotWindow window = WindowAround(grid, d.row, d.col, d.radius_px);
  if (window.empty() || !AnyTileNear(grid, window, depth, radius_mm)) return;
  for (int r = window.r0; r <= window.r1; ++r) {
    const float dr = static_cast<float>(r) - d.row;
    const float half = std::sqrt(std::max(0.f, d.radius_px * d.radius_px - dr * dr));
    const int c0 = std::max(0, Clamped(std::ceil(d.col - half), grid.width));
    const int c1 = std::min(grid.width - 1, Clamped(std::floor(d.col + half), grid.width));
    if (c0 > c1) continue;  // the disc's row lies beside the frame
    const uint32_t row = static_cast<uint32_t>(r) * static_cast<uint32_t>(grid.width);
    for (uint32_t s = row + c0; s <= row + c1; ++s) {
      if (!keep(s)) continue;
      // Empty slots hold NaN: the comparison fails.
      const float dist_sq = (grid.pos[s] - p_in_world).squaredNorm();
      if (dist_sq <= r_sq && !f(s, dist_sq)) return;
    }
  }
}

// Local point spacing of each valid grid point: the mean of the shorter horizontal and the
// shorter vertical neighbour distance (the shorter side stays on the point's own surface at a
// depth jump). NaN for isolated points.
std::vector<float> GridSpacing(const OrganizedPointCloud& g) {
  std::vector<float> s(g.valid.size(), std::numeric_limits<float>::quiet_NaN());
  tbb::parallel_for(0, g.height, [&](int r) {
    for (int c = 0; c < g.width; ++c) {
      const size_t i = g.index(c, r);
      if (!g.valid[i]) continue;
      const Eigen::Vector3d& p = g.cloud.points[i];
      auto nearest = [&](int dc, int dr) {
        double best = std::numeric_limits<double>::infinity();
        for (int sgn : {-1, 1}) {
          const int cc = c + sgn * dc, rr = r + sgn * dr;
          if (cc < 0 || rr < 0 || cc >= g.width || rr >= g.height) continue;
          const size_t j = g.index(cc, rr);
          if (g.valid[j]) best = std::min(best, (g.cloud.points[j] - p).norm());
        }
        return best;
      };
      const double h = nearest(1, 0), v = nearest(0, 1);
      double sum = 0;
      int n = 0;
      for (double d : {h, v}) {
        if (std::isfinite(d)) sum += d, ++n;
      }
      if (n > 0) s[i] = static_cast<float>(sum / n);
    }
  });
  return s;
}

// The border ramp of a point's weight (FusionOptions::border_ramp_px).
double BorderWeight(int border_px, int ramp_px) {
  if (border_px >= ramp_px) return 1;
  const double x = (border_px + 1.0) / (ramp_px + 1.0);
  return x * x;
}

double Median(std::vector<float> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](float x) { return !std::isfinite(x); }), v.end());
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// Candidate centres (FuseViews, step 3): for every overlap point i, the k nearest seeds (by
// seed distance, then centre index) within radius_mm[i] + travel_mm, of any view, into
// candidates[i * k ...] (kNone-padded; the rows of other points are not written).
// The seeds are splatted into every view's grid: each seed projected by the view's fitted
// projection into a bucket of its nearest slot (clamped to the frame). A point then reads the
// buckets of its OWN view within the pixel disc of its search radius (plus the rounding and
// clamping slack): one disc per point instead of one per view, and only the slots holding seeds.
// Points of a view without a fitted projection (or whose disc fails) search every view's seeds
// slot by slot (ForEachNear).
void FindCandidates(const Points& pts, const std::vector<ViewGrid>& grids,
                    const std::vector<uint8_t>& in_overlap, const std::vector<uint32_t>& seeds,
                    float travel_mm, int k_max, int32_t* candidates) {
  constexpr int kMaxCandidates = 16;
  if (k_max < 1 || k_max > kMaxCandidates) throw Error("FindCandidates: k_max out of range");
  const size_t n_views = grids.size(), nc = seeds.size();
  using Found = std::pair<float, int32_t>;
  // Keeps the k_max smallest (distance, centre) pairs in ascending order: the same list as
  // sorting all of them, whatever the order they come in.
  auto insert = [k_max](Found* list, uint8_t* n, const Found& f) {
    if (*n == k_max && !(f < list[k_max - 1])) return;
    int k = *n < k_max ? (*n)++ : k_max - 1;
    for (; k > 0 && f < list[k - 1]; --k) list[k] = list[k - 1];
    list[k] = f;
  };
  // Each point's disc in its own view (the full search radius, with the buckets' slack below;
  // negative where the point has none); per view the largest radius plus slack (seeds
  // projecting farther outside the frame can be near no point of the view).
  std::vector<float> full_radius_px(pts.size(), -1.f);
  // Seeds sit in the bucket of their rounded, frame-clamped projection: rounding moves them by at
  // most 0.71 px; clamping moves no seed farther from a place inside the frame, and the disc's
  // centre lies within `out` of the frame.
  auto bucket_slack = [](const ViewGrid& g, const GridProjection::Bound& b) {
    const float out = std::hypot(b.col - std::clamp(b.col, 0.f, g.width - 1.f),
                                 b.row - std::clamp(b.row, 0.f, g.height - 1.f));
    return 0.71f + 2 * out;
  };
  auto bound_of = [&](size_t i, GridProjection::Bound* b) {
    const ViewGrid& g = grids[pts.view[i]];
    const Eigen::Vector3f x = g.sensor_from_world_r * pts.pos[i] + g.sensor_from_world_t;
    return x.z() > pts.radius_mm[i] + travel_mm && g.projection.BoundAt(x, b);
  };
  // The bound itself where full_radius_px is set, for the query (not initialized elsewhere).
  struct Local {
    float col, row, scale, norm, z;
  };
  const std::unique_ptr<Local[]> local(new Local[pts.size()]);
  tbb::parallel_for(size_t{0}, pts.size(), [&](size_t i) {
    if (!in_overlap[i] || !grids[pts.view[i]].fitted) return;
    GridProjection::Bound b;
    if (!bound_of(i, &b)) return;
    const float radius_px = b.RadiusPx(pts.radius_mm[i] + travel_mm);
    if (!std::isfinite(radius_px)) return;
    full_radius_px[i] = radius_px + bucket_slack(grids[pts.view[i]], b);
    local[i] = {b.col, b.row, b.scale, b.norm, b.z};
  });

  // Per view: the largest disc (px) and search radius (mm) of its points.
  std::vector<float> reach_px(n_views, 0), reach_mm(n_views, 0);
  for (size_t i = 0; i < pts.size(); ++i) {
    if (full_radius_px[i] < 0) continue;
    reach_px[pts.view[i]] = std::max(reach_px[pts.view[i]], full_radius_px[i]);
    reach_mm[pts.view[i]] = std::max(reach_mm[pts.view[i]], pts.radius_mm[i] + travel_mm);
  }
  // Buckets per view: counting sort of the seeds by slot (ascending centre index per slot).
  // A bucket entry: the seed's position and centre index (read together).
  struct Entry {
    Eigen::Vector3f pos;
    int32_t centre;
  };
  std::vector<std::vector<uint32_t>> bucket_start(n_views);
  std::vector<std::vector<Entry>> bucket(n_views);
  {
    std::vector<int32_t> slot_of(nc * n_views, kNone);
    tbb::parallel_for(size_t{0}, nc, [&](size_t c) {
      for (size_t v = 0; v < n_views; ++v) {
        const ViewGrid& g = grids[v];
        if (!g.fitted || reach_px[v] <= 0) continue;
        const Eigen::Vector3f x = g.sensor_from_world_r * pts.pos[seeds[c]] + g.sensor_from_world_t;
        Eigen::Vector2f cr;
        if (!g.projection.Project(x, &cr)) continue;
        const float col = std::clamp(cr.x(), 0.f, g.width - 1.f);
        const float row = std::clamp(cr.y(), 0.f, g.height - 1.f);
        if (std::hypot(cr.x() - col, cr.y() - row) > reach_px[v] + 1) continue;
        // A point q of the view that finds this seed within its search radius has its slot
        // within its disc (<= reach_px) + the fit error of the seed's bucket, and a depth within
        // reach_mm of the seed's: a seed with no such depth in the tiles there (on a surface the
        // view does not see, behind or in front of what it measured) is no view point's
        // candidate and stays out of the view's buckets (a fifth of the entries read on the demo
        // part).
        // Rounded outward (the square holds every slot within span).
        const float span = reach_px[v] + static_cast<float>(g.projection.fit_error_px()) + 2;
        const SlotWindow window{std::max(0, Clamped(std::floor(row - span), g.height)),
                                std::min(g.height - 1, Clamped(std::ceil(row + span), g.height)),
                                std::max(0, Clamped(std::floor(col - span), g.width)),
                                std::min(g.width - 1, Clamped(std::ceil(col + span), g.width))};
        if (!AnyTileNear(g, window, x.z(), reach_mm[v])) continue;
        slot_of[c * n_views + v] =
            static_cast<int32_t>(g.width * std::lround(row) + std::lround(col));
      }
    });
    // Views are independent: sorted in parallel (each serial, in centre order).
    tbb::parallel_for(size_t{0}, n_views, [&](size_t v) {
      if (!grids[v].fitted || reach_px[v] <= 0) return;
      std::vector<uint32_t>& start = bucket_start[v];
      start.assign(grids[v].pos.size() + 1, 0);
      for (size_t c = 0; c < nc; ++c) {
        if (slot_of[c * n_views + v] != kNone) ++start[slot_of[c * n_views + v] + 1];
      }
      for (size_t k = 0; k + 1 < start.size(); ++k) start[k + 1] += start[k];
      bucket[v].resize(start.back());
      std::vector<uint32_t> fill(start.begin(), start.end() - 1);
      for (size_t c = 0; c < nc; ++c) {
        const int32_t slot = slot_of[c * n_views + v];
        if (slot != kNone)
          bucket[v][fill[slot]++] = Entry{pts.pos[seeds[c]], static_cast<int32_t>(c)};
      }
    });
  }

  std::vector<int32_t> seed_at;  // for the slot-by-slot fallback: per view, per slot
  std::vector<size_t> seed_at_start(n_views + 1, 0);
  for (size_t v = 0; v < n_views; ++v)
    seed_at_start[v + 1] = seed_at_start[v] + grids[v].pos.size();
  const bool any_fallback = [&] {
    for (size_t i = 0; i < pts.size(); ++i) {
      if (in_overlap[i] && full_radius_px[i] < 0) return true;
    }
    return false;
  }();
  if (any_fallback) {
    seed_at.assign(seed_at_start.back(), kNone);
    for (size_t c = 0; c < nc; ++c) {
      seed_at[seed_at_start[pts.view[seeds[c]]] + pts.grid[seeds[c]]] = static_cast<int32_t>(c);
    }
  }
  tbb::parallel_for(
      tbb::blocked_range<size_t>(0, pts.size(), 2048),
      [&](const tbb::blocked_range<size_t>& range) {
        Found list[kMaxCandidates];
        for (size_t i = range.begin(); i != range.end(); ++i) {
          if (!in_overlap[i]) continue;
          uint8_t n = 0;
          const Eigen::Vector3f p = pts.pos[i];
          const float r = pts.radius_mm[i] + travel_mm;
          if (full_radius_px[i] >= 0) {
            const ViewGrid& g = grids[pts.view[i]];
            GridProjection::Bound b;
            b.col = local[i].col;
            b.row = local[i].row;
            b.scale = local[i].scale;
            b.norm = local[i].norm;
            b.z = local[i].z;
            b.fit_error_px = static_cast<float>(g.projection.fit_error_px());
            const std::vector<uint32_t>& start = bucket_start[pts.view[i]];
            const std::vector<Entry>& entries = bucket[pts.view[i]];
            const float r_sq = r * r, slack = bucket_slack(g, b), full_px = full_radius_px[i];
            // The disc shrinks as the list fills: once it holds k_max seeds, a nearer one lies
            // within the k_max-th's distance, so within that distance's disc. Rows are read
            // from the disc's centre outwards (the nearest seeds first); a row beyond the
            // current disc ends its side.
            auto radius_px = [&] {
              if (n < k_max) return full_px;
              const float kth = std::min(r, std::sqrt(list[k_max - 1].first) * (1 + 1e-5f));
              return std::min(full_px, b.RadiusPx(kth) + slack);
            };
            // The seeds of one row within the current disc into the list; false when the row
            // lies beyond it.
            auto scan_row = [&](int row) {
              const float rad = radius_px();
              const float dr = static_cast<float>(row) - b.row;
              if (!(std::abs(dr) <= rad)) return false;
              const float half = std::sqrt(std::max(0.f, rad * rad - dr * dr));
              const int c0 = std::max(0, Clamped(std::ceil(b.col - half), g.width));
              const int c1 = std::min(g.width - 1, Clamped(std::floor(b.col + half), g.width));
              if (c0 > c1) return true;
              const size_t base = static_cast<size_t>(row) * static_cast<size_t>(g.width);
              for (uint32_t m = start[base + c0]; m < start[base + c1 + 1]; ++m) {
                const float e_sq = (entries[m].pos - p).squaredNorm();
                if (e_sq <= r_sq) insert(list, &n, Found(e_sq, entries[m].centre));
              }
              return true;
            };
            const int r0 = std::max(0, Clamped(std::ceil(b.row - full_px), g.height));
            const int r1 = std::min(g.height - 1, Clamped(std::floor(b.row + full_px), g.height));
            if (r0 <= r1) {
              int lo = std::clamp(static_cast<int>(std::lround(b.row)), r0, r1), hi = lo + 1;
              bool lo_open = true, hi_open = hi <= r1;
              while (lo_open || hi_open) {
                if (lo_open) lo_open = scan_row(lo) && --lo >= r0;
                if (hi_open) hi_open = scan_row(hi) && ++hi <= r1;
              }
            }
          } else {
            for (size_t v = 0; v < n_views; ++v) {
              const int32_t* seed_of = &seed_at[seed_at_start[v]];
              ForEachNear(
                  grids[v], p, r, [&](uint32_t slot) { return seed_of[slot] != kNone; },
                  [&](uint32_t slot, float dist_sq) {
                    insert(list, &n, Found(dist_sq, seed_of[slot]));
                    return true;
                  });
            }
          }
          for (int k = 0; k < k_max; ++k)
            candidates[i * k_max + k] = k < n ? list[k].second : kNone;
        }
      });
}

// The members of every centre (assign: per point its centre or kNone) in ascending point order,
// centre c's in members[start[c] .. start[c + 1]) (a fixed summation order): a counting sort in
// parallel over a fixed number of point chunks, each counted and then placed in order after the
// chunks before it, so the result does not depend on the threads. count: scratch.
void SortMembers(const std::vector<int32_t>& assign, size_t nc, std::vector<uint32_t>* start,
                 std::vector<uint32_t>* members, std::vector<uint32_t>* count) {
  constexpr size_t kChunks = 4;
  const size_t n = assign.size(), chunk = (n + kChunks - 1) / kChunks;
  count->assign(kChunks * nc, 0);
  tbb::parallel_for(size_t{0}, kChunks, [&](size_t j) {
    uint32_t* cnt = count->data() + j * nc;
    for (size_t k = j * chunk; k < std::min(n, (j + 1) * chunk); ++k) {
      if (assign[k] != kNone) ++cnt[assign[k]];
    }
  });
  // Per centre: its start, and each chunk's first place in it (in the counts' place).
  start->assign(nc + 1, 0);
  uint32_t total = 0;
  for (size_t c = 0; c < nc; ++c) {
    (*start)[c] = total;
    for (size_t j = 0; j < kChunks; ++j) {
      const uint32_t m = (*count)[j * nc + c];
      (*count)[j * nc + c] = total;
      total += m;
    }
  }
  (*start)[nc] = total;
  members->resize(total);
  tbb::parallel_for(size_t{0}, kChunks, [&](size_t j) {
    uint32_t* next = count->data() + j * nc;
    for (size_t k = j * chunk; k < std::min(n, (j + 1) * chunk); ++k) {
      if (assign[k] != kNone) (*members)[next[assign[k]]++] = static_cast<uint32_t>(k);
    }
  });
}

// Single-coverage smoothing (FusionOptions::smooth_radius_px): a passed-through point has no
// other view to average with, so it is averaged with its own view's grid neighbours within
// radius_px (a (2r+1)^2 window) ALONG ITS NORMAL only: it moves by the weighted mean of the
// neighbours' offsets from its tangent plane (itself counting with offset 0), so it keeps its
// place on the surface (no lateral smearing) while its depth noise averages down. Edge
// preserving: neighbours whose normal differs by more than the compatibility angle, or whose
// offset exceeds 3 noise sigmas (of a difference of two points), do not count, and the others
// weigh by their point weight times a Gaussian of the offset (sigma = the noise of a
// difference). The noise sigma is estimated from the data: 1.4826 * the median |offset| of
// every passed point's right-hand grid neighbour, / sqrt(2). Returns one offset per passed
// point (mm, along its normal); 0 for points without a usable normal.
std::vector<float> SingleCoverageOffsets(const Points& pts, const std::vector<ViewGrid>& grids,
                                         const std::vector<uint32_t>& passed, int radius_px,
                                         float cos_max, FusionSummary* s) {
  std::vector<float> offset(passed.size(), 0.f);
  if (radius_px <= 0 || passed.empty()) return offset;
  // Noise along the normal from neighbouring pairs.
  std::vector<float> pair;
  pair.reserve(passed.size());
  for (uint32_t k : passed) {
    if (!pts.usable[k]) continue;
    const ViewGrid& g = grids[pts.view[k]];
    const uint32_t slot = pts.grid[k];
    if ((slot + 1) % static_cast<uint32_t>(g.width) == 0 || g.point[slot + 1] == kNone) continue;
    if (pts.nrm[k].dot(g.nrm[slot + 1]) < cos_max) continue;
    pair.push_back(std::abs(pts.nrm[k].dot(g.pos[slot + 1] - pts.pos[k])));
  }
  if (pair.size() < 10) return offset;
  std::nth_element(pair.begin(), pair.begin() + static_cast<std::ptrdiff_t>(pair.size() / 2),
                   pair.end());
  const float sigma_pair = 1.4826f * pair[pair.size() / 2];  // of a difference of two points
  s->single_coverage_noise_mm = sigma_pair / std::sqrt(2.f);
  if (!(sigma_pair > 0)) return offset;
  const float limit = 3 * sigma_pair;
  tbb::parallel_for(size_t{0}, passed.size(), [&](size_t m) {
    const uint32_t k = passed[m];
    if (!pts.usable[k]) return;
    const ViewGrid& g = grids[pts.view[k]];
    const int col = static_cast<int>(pts.grid[k] % static_cast<uint32_t>(g.width));
    const int row = static_cast<int>(pts.grid[k] / static_cast<uint32_t>(g.width));
    const Eigen::Vector3f p = pts.pos[k], n = pts.nrm[k];
    double sw = std::max(pts.weight[k], 1e-12f), swo = 0;
    for (int r = std::max(0, row - radius_px); r <= std::min(g.height - 1, row + radius_px); ++r) {
      for (int c = std::max(0, col - radius_px); c <= std::min(g.width - 1, col + radius_px); ++c) {
        const size_t slot = static_cast<size_t>(r) * static_cast<size_t>(g.width) + c;
        if ((r == row && c == col) || g.point[slot] == kNone) continue;
        if (n.dot(g.nrm[slot]) < cos_max) continue;
        const float off = n.dot(g.pos[slot] - p);
        if (!(std::abs(off) <= limit)) continue;
        const double w = std::max(g.weight[slot], 1e-12f) *
                         std::exp(-0.5 * (off / sigma_pair) * (off / sigma_pair));
        sw += w;
        swo += w * off;
      }
    }
    offset[m] = static_cast<float>(swo / sw);
  });
  return offset;
}

FusionResult Fail(FusionResult r, FusionStatus status, std::string message) {
  r.summary.status = status;
  r.summary.message = std::move(message);
  return r;
}

}  // namespace

std::vector<uint16_t> BorderDistancePx(const OrganizedPointCloud& g, int min_hole_px) {
  // Border sources: invalid slots in invalid regions (8-connected) of at least min_hole_px.
  std::vector<uint8_t> source(g.valid.size(), 0);
  if (g.width > 0 && g.height > 0) {
    cv::Mat invalid(g.height, g.width, CV_8U);
    for (int r = 0; r < g.height; ++r) {
      for (int c = 0; c < g.width; ++c) invalid.at<uint8_t>(r, c) = g.valid[g.index(c, r)] ? 0 : 1;
    }
    cv::Mat labels, stats, centroids;
    cv::connectedComponentsWithStats(invalid, labels, stats, centroids, 8, CV_32S);
    for (int r = 0; r < g.height; ++r) {
      for (int c = 0; c < g.width; ++c) {
        const int l = labels.at<int32_t>(r, c);
        source[g.index(c, r)] = l > 0 && stats.at<int32_t>(l, cv::CC_STAT_AREA) >= min_hole_px;
      }
    }
  }
  // Two passes of a city-block distance transform; beyond the frame counts as far.
  constexpr int kFar = 65535;
  std::vector<int> d(g.valid.size(), 0);
  for (int r = 0; r < g.height; ++r) {
    for (int c = 0; c < g.width; ++c) {
      const size_t i = g.index(c, r);
      if (source[i]) continue;
      const int left = c > 0 ? d[i - 1] + 1 : kFar;
      const int up = r > 0 ? d[i - static_cast<size_t>(g.width)] + 1 : kFar;
      d[i] = std::min({left, up, kFar});
    }
  }
  for (int r = g.height - 1; r >= 0; --r) {
    for (int c = g.width - 1; c >= 0; --c) {
      const size_t i = g.index(c, r);
      if (source[i]) continue;
      const int right = c + 1 < g.width ? d[i + 1] + 1 : kFar;
      const int down = r + 1 < g.height ? d[i + static_cast<size_t>(g.width)] + 1 : kFar;
      d[i] = std::min({d[i], right, down});
    }
  }
  // d counts steps to the nearest source (1 beside it); the result counts from 0.
  std::vector<uint16_t> out(d.size(), 0);
  for (size_t i = 0; i < d.size(); ++i) {
    out[i] = static_cast<uint16_t>(g.valid[i] ? std::max(d[i] - 1, 0) : 0);
  }
  return out;
}

void FusionOptions::Check() const {
  constexpr const char* kName = "FusionOptions";
  util::CheckOption(spacing_factor > 0 && spacing_factor <= 20, kName, "spacing_factor",
                    spacing_factor, "must be in (0, 20]");
  util::CheckOption(seed_factor > 0 && seed_factor <= 20, kName, "seed_factor", seed_factor,
                    "must be in (0, 20]");
  util::CheckOption(border_seed_factor > 0 && border_seed_factor <= 20, kName, "border_seed_factor",
                    border_seed_factor, "must be in (0, 20]");
  util::CheckOption(border_seed_px >= 0 && border_seed_px <= 100, kName, "border_seed_px",
                    border_seed_px, "must be in [0, 100]");
  util::CheckOption(registration_rms_mm >= 0 && std::isfinite(registration_rms_mm), kName,
                    "registration_rms_mm", registration_rms_mm, "must be finite and >= 0");
  util::CheckOption(registration_factor >= 0 && std::isfinite(registration_factor), kName,
                    "registration_factor", registration_factor, "must be finite and >= 0");
  util::CheckOption(max_normal_angle_deg > 0 && max_normal_angle_deg < 90, kName,
                    "max_normal_angle_deg", max_normal_angle_deg, "must be in (0, 90)");
  util::CheckOption(lateral_sigma > 0 && lateral_sigma <= 10, kName, "lateral_sigma", lateral_sigma,
                    "must be in (0, 10]");
  util::CheckOption(max_disagreement > 1, kName, "max_disagreement", max_disagreement,
                    "must be > 1");
  util::CheckOption(max_iterations >= 1 && max_iterations <= 100, kName, "max_iterations",
                    max_iterations, "must be in [1, 100]");
  util::CheckOption(convergence_mm > 0, kName, "convergence_mm", convergence_mm, "must be > 0");
  util::CheckOption(max_moving_fraction >= 0 && max_moving_fraction < 1, kName,
                    "max_moving_fraction", max_moving_fraction, "must be in [0, 1)");
  util::CheckOption(modulation_half_dn > 0, kName, "modulation_half_dn", modulation_half_dn,
                    "must be > 0");
  util::CheckOption(residual_half_px > 0, kName, "residual_half_px", residual_half_px,
                    "must be > 0");
  util::CheckOption(min_cos_view > 0 && min_cos_view <= 1, kName, "min_cos_view", min_cos_view,
                    "must be in (0, 1]");
  util::CheckOption(border_ramp_px >= 0 && border_ramp_px <= 100, kName, "border_ramp_px",
                    border_ramp_px, "must be in [0, 100]");
  util::CheckOption(border_trim_px >= 0 && border_trim_px <= 100, kName, "border_trim_px",
                    border_trim_px, "must be in [0, 100]");
  util::CheckOption(one_view_cluster_border_px >= 0 && one_view_cluster_border_px <= 100, kName,
                    "one_view_cluster_border_px", one_view_cluster_border_px,
                    "must be in [0, 100]");
  util::CheckOption(smooth_radius_px >= 0 && smooth_radius_px <= 10, kName, "smooth_radius_px",
                    smooth_radius_px, "must be in [0, 10]");
  util::CheckOption(min_border_hole_px >= 1, kName, "min_border_hole_px", min_border_hole_px,
                    "must be >= 1");
  util::CheckOption(max_fit_error_px > 0, kName, "max_fit_error_px", max_fit_error_px,
                    "must be > 0");
  util::CheckOption(max_spacing_ratio > 1, kName, "max_spacing_ratio", max_spacing_ratio,
                    "must be > 1");
}

const char* ToString(FusionStatus s) {
  switch (s) {
    case FusionStatus::kOk:
      return "ok";
    case FusionStatus::kNoOverlap:
      return "no overlap";
    case FusionStatus::kEmptyInput:
      return "empty input";
    case FusionStatus::kMissingNormals:
      return "missing normals";
    case FusionStatus::kUnitsMismatch:
      return "units mismatch";
    case FusionStatus::kBadView:
      return "bad view";
  }
  return "?";
}

std::string FusionSummary::BriefReport() const {
  std::string s = util::StrCat(
      "fusion: ", ToString(status), ", ", views, " views, ", input_points, " points -> ",
      fused_points, " (", overlap_points, " in overlaps -> ", clusters, " clusters, ",
      passed_through, " passed through, ", unassigned, " unassigned and ", absorbed,
      " border points and ", absorbed_clusters, " one-view clusters absorbed by better points, ",
      trimmed, " lone border points trimmed, ", disagreeing_clusters, " kept their best view), ",
      iterations, " iterations (", converged ? "converged" : "not converged", ", ", moving_centres,
      " centres still moving, last max shift ", last_max_shift_mm, " mm), spacing ",
      median_spacing_mm, " mm, ", time_s, " s");
  if (!message.empty()) s += ": " + message;
  return s;
}

nlohmann::json ToJson(const FusionSummary& s) {
  return {{"status", ToString(s.status)},
          {"message", s.message},
          {"views", s.views},
          {"input_points", s.input_points},
          {"overlap_points", s.overlap_points},
          {"clusters", s.clusters},
          {"passed_through", s.passed_through},
          {"unassigned", s.unassigned},
          {"absorbed", s.absorbed},
          {"absorbed_clusters", s.absorbed_clusters},
          {"trimmed", s.trimmed},
          {"disagreeing_clusters", s.disagreeing_clusters},
          {"fused_points", s.fused_points},
          {"iterations", s.iterations},
          {"last_max_shift_mm", s.last_max_shift_mm},
          {"moving_centres", s.moving_centres},
          {"converged", s.converged},
          {"median_spacing_mm", s.median_spacing_mm},
          {"single_coverage_noise_mm", s.single_coverage_noise_mm},
          {"max_fit_error_px", s.max_fit_error_px},
          {"time_s", s.time_s},
          {"prepare_s", s.prepare_s},
          {"overlap_s", s.overlap_s},
          {"candidates_s", s.candidates_s},
          {"cluster_s", s.cluster_s},
          {"output_s", s.output_s}};
}

namespace {

// Point flags of the overlap search (FindOverlap). kOutranked: a compatible point of another
// view within the radius outranks this one.
constexpr uint8_t kOverlap = 1, kSeed = 2, kAbsorbed = 4, kOutranked = 8;

// What a stage refuses its input with: FuseViews returns it as the result's status.
struct Refusal {
  FusionStatus status;
  std::string message;
};

// The registration term of every radius (FusionOptions::registration_factor).
double RegistrationTerm(const FusionOptions& options) {
  return options.registration_factor * options.registration_rms_mm;
}

// Stage "prepare", 1: each view's sizes, pose and normals checked, its grid spacing and border
// distances; the units check compares median spacings.
struct ViewMeasures {
  std::vector<std::vector<float>> spacing;
  std::vector<std::vector<uint16_t>> border;
  std::vector<double> median_spacing;
  int64_t total = 0;  // valid points of all views
};

std::optional<Refusal> MeasureViews(const std::vector<FusionView>& views,
                                    const FusionOptions& options, ViewMeasures* m,
                                    FusionSummary* s) {
  m->spacing.resize(views.size());
  m->border.resize(views.size());
  m->median_spacing.assign(views.size(), 0);
  int64_t total = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    const FusionView& fv = views[v];
    const OrganizedPointCloud& g = fv.cloud;
    const size_t n = static_cast<size_t>(std::max(g.width, 0)) * std::max(g.height, 0);
    const PointCloud& c = g.cloud;
    auto sized = [n](const auto& a) { return a.empty() || a.size() == n; };
    if (g.cloud.size() != n || g.valid.size() != n || !sized(c.normals) || !sized(c.intensity) ||
        !sized(c.quality) || !sized(c.residual_px) || !sized(c.colors)) {
      return Refusal{FusionStatus::kBadView,
                     util::StrCat("view '", fv.name, "': grid ", g.width, "x", g.height,
                                  " disagrees with its attribute sizes")};
    }
    const Eigen::Matrix<double, 3, 4> pose = fv.world_from_sensor.ToMatrix3x4();
    if (!pose.allFinite()) {
      return Refusal{FusionStatus::kBadView, util::StrCat("view '", fv.name, "': non-finite pose")};
    }
    const size_t valid = g.NumValid();
    if (valid > 0 && !c.has_normals()) {
      return Refusal{FusionStatus::kMissingNormals,
                     util::StrCat("view '", fv.name,
                                  "' has no normals (reconstruct with normals, or estimate them)")};
    }
    total += static_cast<int64_t>(valid);
  }
  // Per view, independent: in parallel (the border transform is serial within a view).
  tbb::parallel_for(size_t{0}, views.size(), [&](size_t v) {
    m->spacing[v] = GridSpacing(views[v].cloud);
    m->border[v] = BorderDistancePx(views[v].cloud, options.min_border_hole_px);
    m->median_spacing[v] = Median(m->spacing[v]);
  });
  m->total = total;
  s->input_points = total;
  if (total == 0) return Refusal{FusionStatus::kEmptyInput, "no valid point in any view"};
  const std::vector<double>& median_spacing = m->median_spacing;
  size_t lo = views.size(), hi = views.size();
  for (size_t v = 0; v < views.size(); ++v) {
    if (!std::isfinite(median_spacing[v])) continue;
    if (lo == views.size() || median_spacing[v] < median_spacing[lo]) lo = v;
    if (hi == views.size() || median_spacing[v] > median_spacing[hi]) hi = v;
  }
  if (lo != views.size() && median_spacing[hi] > options.max_spacing_ratio * median_spacing[lo]) {
    return Refusal{
        FusionStatus::kUnitsMismatch,
        util::StrCat("view '", views[hi].name, "' has a point spacing of ", median_spacing[hi],
                     " and view '", views[lo].name, "' of ", median_spacing[lo],
                     " (different units? all clouds must be in millimetres)")};
  }
  return std::nullopt;
}

// Stage "prepare", 2: the valid points in the world frame with weight and adaptive radius, in
// view order.
std::optional<Refusal> GatherPoints(const std::vector<FusionView>& views,
                                    const FusionOptions& options, const ViewMeasures& m,
                                    Points* out, FusionSummary* s) {
  Points& pts = *out;
  const int64_t total = m.total;
  pts.pos.resize(total);
  pts.nrm.resize(total);
  pts.weight.resize(total);
  pts.radius_mm.resize(total);
  pts.spacing_mm.resize(total);
  pts.seed_radius_mm.resize(total);
  pts.intensity.resize(total);
  pts.quality.resize(total);
  pts.view.resize(total);
  pts.grid.resize(total);
  pts.border.resize(total);
  pts.usable.resize(total);
  {
    size_t k = 0;
    for (size_t v = 0; v < views.size(); ++v) {
      const OrganizedPointCloud& g = views[v].cloud;
      for (size_t i = 0; i < g.valid.size(); ++i) {
        if (!g.valid[i]) continue;
        pts.view[k] = static_cast<uint16_t>(v);
        pts.grid[k] = static_cast<uint32_t>(i);
        ++k;
      }
    }
    std::vector<float> all_spacing;
    all_spacing.reserve(total);
    for (size_t v = 0; v < views.size(); ++v) {
      for (float x : m.spacing[v]) {
        if (std::isfinite(x)) all_spacing.push_back(x);
      }
    }
    s->median_spacing_mm = Median(std::move(all_spacing));
  }
  const double reg_term = RegistrationTerm(options);
  std::atomic<bool> nonfinite{false};
  tbb::parallel_for(
      tbb::blocked_range<size_t>(0, static_cast<size_t>(total)),
      [&](const tbb::blocked_range<size_t>& range) {
        for (size_t k = range.begin(); k != range.end(); ++k) {
          const FusionView& fv = views[pts.view[k]];
          const PointCloud& c = fv.cloud.cloud;
          const uint32_t i = pts.grid[k];
          const Eigen::Vector3d& p_in_sensor = c.points[i];
          const Eigen::Vector3d& n_in_sensor = c.normals[i];
          if (!p_in_sensor.allFinite()) nonfinite = true;
          pts.pos[k] = (fv.world_from_sensor * p_in_sensor).cast<float>();
          pts.usable[k] = n_in_sensor.allFinite() && std::abs(n_in_sensor.norm() - 1) < 1e-3;
          pts.nrm[k] = fv.world_from_sensor.RotateDirection(n_in_sensor).cast<float>();
          const double cos_view = std::max(
              options.min_cos_view, std::abs(n_in_sensor.dot(p_in_sensor)) / p_in_sensor.norm());
          double w = cos_view * cos_view;
          if (c.has_quality()) {
            const double b2 = static_cast<double>(c.quality[i]) * c.quality[i];
            w *= b2 / (b2 + options.modulation_half_dn * options.modulation_half_dn);
          }
          if (c.has_residual() && std::isfinite(c.residual_px[i])) {
            const double q = c.residual_px[i] / options.residual_half_px;
            w *= 1 / (1 + q * q);
          }
          pts.border[k] = m.border[pts.view[k]][i];
          w *= BorderWeight(pts.border[k], options.border_ramp_px);
          pts.weight[k] = static_cast<float>(std::isfinite(w) ? w : 0);
          // Isolated points take the view's median spacing; grazing ones at most 4 times it
          // (the radius sets the pixel windows of the neighbour search).
          const float median = static_cast<float>(m.median_spacing[pts.view[k]]);
          float sp = m.spacing[pts.view[k]][i];
          sp = std::isfinite(sp) ? std::min(sp, 4 * median) : median;
          pts.spacing_mm[k] = sp;
          pts.radius_mm[k] = static_cast<float>(options.spacing_factor * sp + reg_term);
          // Near a border the seed radius is wider (FusionOptions::border_seed_factor).
          const double seed_factor = pts.border[k] < options.border_seed_px
                                         ? std::max(options.seed_factor, options.border_seed_factor)
                                         : options.seed_factor;
          pts.seed_radius_mm[k] = static_cast<float>(seed_factor * sp + reg_term);
          pts.intensity[k] = c.has_intensity() ? c.intensity[i] : 0.f;
          pts.quality[k] = c.has_quality() ? c.quality[i] : 0.f;
        }
      });
  if (nonfinite) {
    return Refusal{FusionStatus::kBadView, "a valid point has a non-finite position"};
  }
  for (size_t k = 0; k < pts.size(); ++k) {
    if (!std::isfinite(pts.radius_mm[k])) pts.usable[k] = 0;
  }
  return std::nullopt;
}

// Stage "prepare", 3: the views' grids for the neighbour search, each with its fitted
// projection; view_start[v] .. view_start[v + 1]: view v's points.
std::optional<Refusal> BuildGrids(const std::vector<FusionView>& views,
                                  const FusionOptions& options, const Points& pts,
                                  std::vector<size_t>* view_start_out,
                                  std::vector<ViewGrid>* grids_out, FusionSummary* s) {
  std::vector<ViewGrid>& grids = *grids_out;
  grids.assign(views.size(), ViewGrid());
  std::vector<size_t>& view_start = *view_start_out;
  view_start.assign(views.size() + 1, 0);
  for (size_t k = 0; k < pts.size(); ++k) ++view_start[pts.view[k] + 1];
  for (size_t v = 0; v < views.size(); ++v) view_start[v + 1] += view_start[v];
  tbb::parallel_for(size_t{0}, views.size(), [&](size_t v) {
    const OrganizedPointCloud& g = views[v].cloud;
    ViewGrid& grid = grids[v];
    grid.width = g.width;
    grid.height = g.height;
    grid.point.assign(g.valid.size(), kNone);
    grid.pos.assign(g.valid.size(),
                    Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
    grid.nrm.assign(g.valid.size(), Eigen::Vector3f::Zero());
    grid.weight.assign(g.valid.size(), 0.f);
    for (size_t k = view_start[v]; k < view_start[v + 1]; ++k) {
      if (!pts.usable[k]) continue;
      grid.point[pts.grid[k]] = static_cast<int32_t>(k);
      grid.pos[pts.grid[k]] = pts.pos[k];
      grid.nrm[pts.grid[k]] = pts.nrm[k];
      grid.weight[pts.grid[k]] = pts.weight[k];
      grid.usable_slots.push_back(pts.grid[k]);
    }
    const Rigid3d sensor_from_world = views[v].world_from_sensor.Inverse();
    grid.sensor_from_world_r = sensor_from_world.rotation_matrix().cast<float>();
    grid.sensor_from_world_t = sensor_from_world.translation().cast<float>();
    grid.origin_in_world = views[v].world_from_sensor.translation().cast<float>();
    grid.projection = GridProjection::Fit(g);
    grid.fitted = grid.projection.fitted();
    FillTileDepths(&grid);
  });
  for (size_t v = 0; v < views.size(); ++v) {
    const double fit_err_px = grids[v].projection.fit_error_px();
    if (fit_err_px > options.max_fit_error_px) {
      return Refusal{FusionStatus::kBadView,
                     util::StrCat("view '", views[v].name,
                                  "': its grid is not a camera's pixel grid (the points project "
                                  "to their slots with errors up to ",
                                  fit_err_px,
                                  " px; fusion needs the organized cloud as "
                                  "reconstructed, in its sensor frame)")};
    }
    s->max_fit_error_px =
        std::max(s->max_fit_error_px,
                 grids[v].fitted ? static_cast<double>(static_cast<float>(fit_err_px)) : 0.0);
  }
  return std::nullopt;
}

// The normal compatibility test: cos and sin of FusionOptions::max_normal_angle_deg.
float CosMax(const FusionOptions& o) {
  return static_cast<float>(std::cos(o.max_normal_angle_deg * kPi / 180));
}
float SinMax(const FusionOptions& o) {
  return static_cast<float>(std::sin(o.max_normal_angle_deg * kPi / 180));
}

// Stage "overlap" (steps 1 + 2: overlap and initial centres): each point against the other
// views' points in the pixel windows around its projections; per point its flags (kOverlap,
// kSeed, kAbsorbed, kOutranked).
std::vector<uint8_t> FindOverlap(const Points& pts, const std::vector<ViewGrid>& grids,
                                 const std::vector<size_t>& view_start,
                                 const FusionOptions& options) {
  const float cos_max = CosMax(options);
  const float sin_max = SinMax(options);
  std::vector<uint8_t> flags(pts.size(), 0);
  // Blocks of consecutive points, and within a block view by view: the windows of a block's
  // points in one other view cover a few of its grid rows, which stay in the cache while the
  // block's points read them (point by point over all views, every view's rows would compete).
  // Every flag is an OR (or AND) over the views: the order changes nothing. A point outranked
  // within its seed radius by a compatible point is settled (an overlap point, no seed): the
  // remaining views are not searched for it.
  //
  // Per tile of a view's grid (ViewGrid::kTile) and other view: 1 when no point of that view
  // can lie within the radius of any of the tile's points (the sphere around the tile's points'
  // bounding box, widened by their largest radius, projects outside the other view's frame or
  // onto tiles without a depth within reach): its points skip that view without computing a
  // disc each (a third of the overlap search's discs found nothing on the demo part).
  // Beside it the largest weight of that view's points there (+inf where no bound was taken):
  // a point with a larger weight (or an equal one and a smaller view index) has no point of
  // that view that outranks it.
  std::vector<std::vector<uint8_t>> far_view(grids.size());
  std::vector<std::vector<float>> near_wmax(grids.size());
  tbb::parallel_for(size_t{0}, grids.size(), [&](size_t u) {
    const ViewGrid& gu = grids[u];
    const size_t n_tiles = static_cast<size_t>(gu.tiles_w) * static_cast<size_t>(gu.tiles_h);
    std::vector<Eigen::AlignedBox3f> box(n_tiles);
    std::vector<float> reach(n_tiles, 0.f);
    for (size_t k = view_start[u]; k < view_start[u + 1]; ++k) {
      if (!pts.usable[k]) continue;
      const size_t t = TileOf(gu, pts.grid[k]);
      box[t].extend(pts.pos[k]);
      reach[t] = std::max(reach[t], pts.radius_mm[k]);
    }
    std::vector<uint8_t>& far = far_view[u];
    far.assign(n_tiles * grids.size(), 0);
    std::vector<float>& wmax = near_wmax[u];
    wmax.assign(n_tiles * grids.size(), std::numeric_limits<float>::infinity());
    for (size_t t = 0; t < n_tiles; ++t) {
      if (box[t].isEmpty()) continue;
      const Eigen::Vector3f centre = box[t].center();
      const float rho = 0.5f * box[t].diagonal().norm() + reach[t];
      for (size_t v = 0; v < grids.size(); ++v) {
        const ViewGrid& g = grids[v];
        if (v == u || !g.fitted) continue;
        GridProjection::Disc d;
        float depth = 0;
        // Behind the camera or not finite: no decision, the points search as they are.
        if (!DiscOf(g, centre, rho, &d, &depth)) continue;
        // The disc's bound is taken at its centre: over a tile-sized disc it is widened by 10 %
        // and a pixel so that the skip never depends on the Jacobian's change across it.
        const SlotWindow window = WindowAround(g, d.row, d.col, 1.1f * d.radius_px + 1);
        far[t * grids.size() + v] = window.empty() || !AnyTileNear(g, window, depth, rho);
        if (!far[t * grids.size() + v])
          wmax[t * grids.size() + v] = MaxWeightNear(g, window, depth, rho);
      }
    }
  });
  // Two passes per block, each view by view. A point that is no seed has a compatible point of
  // another view that outranks it within its seed radius: the first pass reads only the discs
  // of the seed radius (a fifth of the overlap radius' area or less on the demo part), and about
  // three points in four settle there. The second pass (full radius) is for the points that did
  // not: their seed flag is final after the first pass (no outranking compatible point within the
  // seed radius in any view), what remains is whether they overlap and are outranked at all —
  // a point that is both stops — and, for a border point outside every overlap, whether a
  // better point lies within its radius. Every flag is the same OR over the same neighbours as
  // one full pass.
  constexpr size_t kBlock = 2048;
  tbb::parallel_for(
      tbb::blocked_range<size_t>(0, pts.size(), kBlock),
      [&](const tbb::blocked_range<size_t>& range) {
        struct State {
          bool overlap = false, seed = true, better = false, outranked = false;
        };
        std::vector<State> state(range.size());
        std::vector<const uint8_t*> far_of(range.size());
        std::vector<const float*> wmax_of(range.size());
        for (size_t i = range.begin(); i != range.end(); ++i) {
          const size_t t = TileOf(grids[pts.view[i]], pts.grid[i]) * grids.size();
          far_of[i - range.begin()] = &far_view[pts.view[i]][t];
          wmax_of[i - range.begin()] = &near_wmax[pts.view[i]][t];
        }
        for (int pass = 0; pass < 2; ++pass) {
          for (size_t v = 0; v < grids.size(); ++v) {
            const ViewGrid& grid = grids[v];
            for (size_t i = range.begin(); i != range.end(); ++i) {
              if (!pts.usable[i] || v == pts.view[i]) continue;
              State& st = state[i - range.begin()];
              // Settled: no seed (first pass), or overlapping and outranked (second pass).
              auto settled = [&] { return st.overlap && (!st.seed || st.outranked); };
              if (st.overlap && !st.seed) continue;
              if (pass == 1 && st.overlap && st.outranked) continue;
              if (far_of[i - range.begin()][v]) continue;
              const float w = pts.weight[i];
              // No point of view v here can outrank this one: it cannot settle it (first pass),
              // nor make it outranked, and once it overlaps that is all v could add.
              const float wv = wmax_of[i - range.begin()][v];
              const bool can_outrank = wv > w || (wv == w && v < pts.view[i]);
              if (!can_outrank && (pass == 0 || st.overlap)) continue;
              const Eigen::Vector3f p = pts.pos[i];
              const Eigen::Vector3f n = pts.nrm[i];
              const bool border = pts.border[i] < options.border_trim_px;
              // Normals face their sensor: a view that sees p's side from behind by
              // more than the compatibility angle has no compatible point there (only a
              // border point needs the others: `better`).
              if (!border && n.dot((grid.origin_in_world - p).normalized()) < -sin_max) continue;
              const float seed_sq = pts.seed_radius_mm[i] * pts.seed_radius_mm[i];
              const float radius =
                  pass == 0 ? std::min(pts.seed_radius_mm[i], pts.radius_mm[i]) : pts.radius_mm[i];
              ForEachNear(
                  grid, p, radius, [](uint32_t) { return true; },
                  [&](uint32_t slot, float dist_sq) {
                    if (pass == 0 ? st.overlap && !st.seed : settled()) return false;
                    const float wj = grid.weight[slot];
                    st.better = st.better || wj > w;
                    if (n.dot(grid.nrm[slot]) < cos_max) return true;
                    st.overlap = true;
                    // Outranks(j, i): weight, then view index (v != the point's view).
                    if (wj > w || (wj == w && v < pts.view[i])) {
                      st.outranked = true;
                      if (dist_sq <= seed_sq) st.seed = false;
                    }
                    return true;
                  });
            }
          }
        }
        for (size_t i = range.begin(); i != range.end(); ++i) {
          const State& st = state[i - range.begin()];
          const bool border = pts.border[i] < options.border_trim_px;
          if (st.overlap) {
            flags[i] = static_cast<uint8_t>((st.seed ? (kOverlap | kSeed) : kOverlap) |
                                            (st.outranked ? kOutranked : 0));
          } else if (st.better && border) {
            flags[i] = kAbsorbed;
          }
        }
      });

  return flags;
}

// Candidate centres per overlap point (stage "candidates", FindCandidates).
constexpr int kCandidates = 8;

// The clusters' centres: position and normal, the same side by side for the assignment (it
// reads both for eight candidates per point, at scattered centres: one cache line each), the
// seed's spacing and how far the centre may travel from its seed.
struct Centres {
  struct Placed {
    Eigen::Vector3f pos, nrm;
  };
  std::vector<Eigen::Vector3f> pos, nrm;
  std::vector<Placed> placed;
  std::vector<float> spacing, travel_mm;
  double max_travel_mm = 0;
  size_t size() const { return pos.size(); }
};

// Per point its centre (kNone: none); the members of centre c, in ascending point order, are
// members[start[c] .. start[c + 1]) (SortMembers; count: its scratch).
struct Membership {
  std::vector<int32_t> assign;
  std::vector<uint32_t> start, members, count;
};

// Stage "candidates", 1: a centre at every seed. Centres start at the seeds and move along their
// normals only. Each centre's total travel from its seed is bounded (half a median spacing + the
// registration term, at most the seed radius: a cluster that would travel farther is no surface
// estimate anymore).
Centres SeedCentres(const Points& pts, const std::vector<uint32_t>& seeds, double travel_limit_mm) {
  const size_t nc = seeds.size();
  Centres c;
  c.pos.resize(nc);
  c.nrm.resize(nc);
  c.placed.resize(nc);
  c.spacing.resize(nc);
  c.travel_mm.resize(nc);
  for (size_t k = 0; k < nc; ++k) {
    c.pos[k] = pts.pos[seeds[k]];
    c.nrm[k] = pts.nrm[seeds[k]];
    c.placed[k] = {c.pos[k], c.nrm[k]};
    c.spacing[k] = pts.spacing_mm[seeds[k]];
    c.travel_mm[k] = std::min(pts.seed_radius_mm[seeds[k]], static_cast<float>(travel_limit_mm));
    c.max_travel_mm = std::max(c.max_travel_mm, static_cast<double>(c.travel_mm[k]));
  }
  return c;
}

// Stage "cluster": one centre's step along its normal from its members, the step by its seed
// view's members alone, the spread of the views' steps (NaN with one view) and the members'
// combined normal (the centre's own where they give none).
struct CentreStep {
  double step = 0, own_step = 0, disagreement = kNaN;
  Eigen::Vector3f normal;
};

CentreStep EvaluateCentre(const Points& pts, const Centres& centres, const Membership& members,
                          size_t c, uint16_t seed_view, const FusionOptions& options) {
  CentreStep r;
  r.normal = centres.nrm[c];
  // Each view's surface is evaluated on the centre's normal line: every member gives the
  // point where its tangent plane crosses that line (exact for a member on the same plane
  // however far it lies sideways); within a view, members close beside the line count
  // most (curvature and normal errors near edges grow with the sideways distance). Views
  // then combine by their points' weights, however many members each has, so that a view
  // with two members does not pull twice as hard.
  struct PerView {
    uint16_t view;
    double lw = 0, lw_along = 0, lateral = 0;
  };
  PerView per_view[8];
  int n_views = 0;
  Eigen::Vector3d sn = Eigen::Vector3d::Zero();
  const Eigen::Vector3d n = centres.nrm[c].cast<double>();
  const double lateral_sigma = options.lateral_sigma * centres.spacing[c];
  for (uint32_t m = members.start[c]; m < members.start[c + 1]; ++m) {
    const uint32_t i = members.members[m];
    const Eigen::Vector3d d = (pts.pos[i] - centres.pos[c]).cast<double>();
    const Eigen::Vector3d ni = pts.nrm[i].cast<double>();
    const double along = ni.dot(d) / std::max(ni.dot(n), 0.7);
    const double lateral_sq = (d - n.dot(d) * n).squaredNorm();
    const double lat = std::exp(-0.5 * lateral_sq / (lateral_sigma * lateral_sigma));
    const double lw = std::max(pts.weight[i], 1e-12f) * lat;
    int k = 0;
    while (k < n_views && per_view[k].view != pts.view[i]) ++k;
    if (k == n_views) {
      if (n_views == 8) continue;  // more than 8 views in one cluster: the rest add nothing
      per_view[n_views++] = PerView{pts.view[i]};
    }
    per_view[k].lw += lw;
    per_view[k].lw_along += lw * along;
    per_view[k].lateral += lat;
    sn += lw * ni;
  }
  double sw = 0, sd = 0;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  int used = 0;
  for (int k = 0; k < n_views; ++k) {
    if (per_view[k].lw <= 0) continue;
    const double view_weight = per_view[k].lw / per_view[k].lateral;  // mean point weight
    const double e = per_view[k].lw_along / per_view[k].lw;
    sw += view_weight;
    sd += view_weight * e;
    lo = std::min(lo, e);
    hi = std::max(hi, e);
    ++used;
    if (per_view[k].view == seed_view) r.own_step = e;
  }
  if (sw <= 0) return r;
  r.step = sd / sw;
  if (used >= 2) r.disagreement = hi - lo;
  if (sn.norm() > 0) r.normal = sn.normalized().cast<float>();
  return r;
}

// Stage "cluster": the centres move along their normals to their members' surface, the
// members are reassigned to their nearest compatible candidate centre, until (almost) every
// centre settles (FusionOptions::max_iterations, convergence_mm, max_moving_fraction).
void ClusterPoints(const Points& pts, const std::vector<uint8_t>& in_overlap,
                   const std::vector<uint32_t>& seeds, const int32_t* candidates,
                   const FusionOptions& options, Centres* centres_io, Membership* membership_io,
                   FusionSummary* summary) {
  Centres& centres = *centres_io;
  Membership& membership = *membership_io;
  FusionSummary& s = *summary;
  const size_t nc = centres.size();
  const float cos_max = CosMax(options);
  std::vector<Eigen::Vector3f>& centre = centres.pos;
  std::vector<Eigen::Vector3f>& centre_n = centres.nrm;
  std::vector<Centres::Placed>& placed = centres.placed;
  const std::vector<float>& travel_mm = centres.travel_mm;
  std::vector<int32_t>& assign = membership.assign;
  std::vector<uint8_t> keep_own(nc, 0);
  // Iterations. A point's assignment can change only when one of its candidate centres moved
  // in the last iteration, a centre's update only when its membership changed or it moved: a
  // centre whose update would move it less than convergence_mm with unchanged membership
  // settles (stays where it is) and is not evaluated again until its membership changes.
  // Every decision depends on the input only: the result does not depend on the threads.
  std::vector<uint8_t> moved(nc, 1), changed(nc, 1);
  std::vector<uint64_t> moved_bits((nc + 63) / 64, 0);
  std::vector<int32_t> new_assign(pts.size(), kNone);
  // Per centre, from its last evaluation: the combined step along the normal, the step by the
  // seed's own view alone, the spread of the views' steps (NaN with one view) and the combined
  // normal.
  std::vector<double> step(nc, 0), own_step(nc, 0), disagreement(nc, kNaN);
  std::vector<Eigen::Vector3f> new_normal(centre_n);
  std::vector<uint8_t> evaluate(nc, 0);
  std::vector<float> shift(nc, 0.f);
  s.converged = nc == 0;
  for (int it = 0; it < options.max_iterations && nc > 0; ++it) {
    // `moved` as bits (an eighth of the bytes: the eight scattered reads per point below stay
    // in the cache).
    tbb::parallel_for(size_t{0}, moved_bits.size(), [&](size_t w) {
      uint64_t bits = 0;
      for (size_t c = 64 * w; c < std::min(nc, 64 * w + 64); ++c) {
        bits |= static_cast<uint64_t>(moved[c] != 0) << (c - 64 * w);
      }
      moved_bits[w] = bits;
    });
    tbb::parallel_for(tbb::blocked_range<size_t>(0, pts.size(), 4096),
                      [&](const tbb::blocked_range<size_t>& range) {
                        for (size_t i = range.begin(); i != range.end(); ++i) {
                          new_assign[i] = assign[i];
                          if (!in_overlap[i]) continue;
                          const int32_t* cand = &candidates[i * kCandidates];
                          bool stale = it == 0;
                          for (int k = 0; k < kCandidates && cand[k] != kNone && !stale; ++k) {
                            stale = (moved_bits[cand[k] / 64] >> (cand[k] % 64) & 1) != 0;
                          }
                          if (!stale) continue;
                          const float r_sq = pts.radius_mm[i] * pts.radius_mm[i];
                          int32_t best = kNone;
                          float best_d = std::numeric_limits<float>::infinity();
                          for (int k = 0; k < kCandidates && cand[k] != kNone; ++k) {
                            const int32_t c = cand[k];
                            const float dist_sq = (placed[c].pos - pts.pos[i]).squaredNorm();
                            if (dist_sq > r_sq || pts.nrm[i].dot(placed[c].nrm) < cos_max) continue;
                            if (dist_sq < best_d || (dist_sq == best_d && c < best)) {
                              best = c;
                              best_d = dist_sq;
                            }
                          }
                          new_assign[i] = best;
                        }
                      });
    // Memberships that changed (serial: each centre's flag is written by one thread).
    std::fill(changed.begin(), changed.end(), it == 0 ? 1 : 0);
    bool any_change = it == 0;
    for (size_t k = 0; k < pts.size(); ++k) {
      if (new_assign[k] == assign[k]) continue;
      if (assign[k] != kNone) changed[assign[k]] = 1;
      if (new_assign[k] != kNone) changed[new_assign[k]] = 1;
      assign[k] = new_assign[k];
      any_change = true;
    }
    if (any_change) {
      SortMembers(assign, nc, &membership.start, &membership.members, &membership.count);
    }
    tbb::parallel_for(size_t{0}, nc, [&](size_t c) {
      evaluate[c] = changed[c] || moved[c];
      if (!evaluate[c]) return;
      const CentreStep r = EvaluateCentre(pts, centres, membership, c, pts.view[seeds[c]], options);
      step[c] = r.step;
      own_step[c] = r.own_step;
      disagreement[c] = r.disagreement;
      new_normal[c] = r.normal;
    });
    // Views that disagree far more than views usually do (robust scale of all clusters'
    // disagreements: noise + registration) do not see the same smooth surface there — an edge
    // or fine detail their normals blur. Such a centre keeps its seed view's measurement.
    double limit = std::numeric_limits<double>::infinity();
    {
      std::vector<double> d;
      for (double x : disagreement) {
        if (std::isfinite(x)) d.push_back(x);
      }
      if (!d.empty()) {
        std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
        limit = options.max_disagreement * d[d.size() / 2];
      }
    }
    // Once disagreeing, a centre stays with its seed view (the iteration then converges). A
    // centre that turns disagreeing without being evaluated now moves at its next evaluation.
    int64_t rejected = 0;
    for (size_t c = 0; c < nc; ++c) {
      if (disagreement[c] > limit && !keep_own[c]) {
        keep_own[c] = 1;
        if (!evaluate[c]) changed[c] = 2;
      }
      rejected += keep_own[c];
    }
    s.disagreeing_clusters = rejected;
    tbb::parallel_for(size_t{0}, nc, [&](size_t c) {
      shift[c] = 0;
      if (!evaluate[c]) {
        moved[c] = changed[c] == 2;  // re-evaluate with its seed view's step
        return;
      }
      const bool disagree = keep_own[c] != 0;
      const double d = disagree ? own_step[c] : step[c];
      Eigen::Vector3d moved_to = centre[c].cast<double>() + d * centre_n[c].cast<double>();
      const Eigen::Vector3d from_seed = moved_to - pts.pos[seeds[c]].cast<double>();
      if (from_seed.norm() > travel_mm[c]) {
        moved_to = pts.pos[seeds[c]].cast<double>() + from_seed * (travel_mm[c] / from_seed.norm());
      }
      shift[c] = static_cast<float>((moved_to - centre[c].cast<double>()).norm());
      if (shift[c] < options.convergence_mm && !changed[c]) {
        moved[c] = 0;  // settled
        return;
      }
      moved[c] = 1;
      centre[c] = moved_to.cast<float>();
      if (!disagree) centre_n[c] = new_normal[c];
      placed[c] = {centre[c], centre_n[c]};
    });
    s.iterations = it + 1;
    s.last_max_shift_mm = *std::max_element(shift.begin(), shift.end());
    // Converged when (almost) every centre has settled: a few dozen centres on edges can
    // alternate between two memberships for many iterations, by micrometres, and change
    // nothing measurable (half-rig demo scan: from the fourth iteration on, a few dozen centres
    // still move by >= 1 um per iteration).
    int64_t moving = 0;
    for (size_t c = 0; c < nc; ++c) moving += shift[c] >= options.convergence_mm;
    s.moving_centres = moving;
    s.converged =
        static_cast<double>(moving) <= options.max_moving_fraction * static_cast<double>(nc);
    if (s.converged) break;
    if (std::find(moved.begin(), moved.end(), 1) == moved.end()) break;
  }
}

// Stage "output": the kept centres (with their members' weighted intensity and quality), then
// the points no other view covers (smoothed along their normals), absorbed, unassigned and
// trimmed points counted.
void WriteFused(const std::vector<FusionView>& views, const Points& pts,
                const std::vector<ViewGrid>& grids, const std::vector<uint8_t>& flags,
                const std::vector<uint8_t>& in_overlap, const std::vector<uint32_t>& seeds,
                const Centres& centres, const Membership& membership, const FusionOptions& options,
                FusionResult* result) {
  // Output: centres with members, then the passed-through points.
  PointCloud& out = result->fused;
  FusionSummary& s = result->summary;
  const size_t nc = centres.size();
  const std::vector<uint32_t>& member_start = membership.start;
  const std::vector<uint32_t>& members = membership.members;
  const std::vector<int32_t>& assign = membership.assign;
  const float cos_max = CosMax(options);
  // Per centre (in parallel): its views, weighted intensity and quality, and whether it is kept.
  struct Cluster {
    float intensity = 0, quality = 0;
    uint16_t distinct = 0;
    uint8_t keep = 0, absorbed = 0;
  };
  std::vector<Cluster> cluster(nc);
  tbb::parallel_for(size_t{0}, nc, [&](size_t c) {
    if (member_start[c + 1] == member_start[c]) return;
    double sw = 0, si = 0, sq = 0;
    uint64_t view_bits[4] = {0, 0, 0, 0};  // distinct views among the first 256
    int distinct = 0;
    for (uint32_t m = member_start[c]; m < member_start[c + 1]; ++m) {
      const uint32_t i = members[m];
      const double w = std::max(pts.weight[i], 1e-12f);
      sw += w;
      si += w * pts.intensity[i];
      sq += w * pts.quality[i];
      const uint16_t v = std::min<uint16_t>(pts.view[i], 255);
      if (!(view_bits[v / 64] >> (v % 64) & 1)) {
        view_bits[v / 64] |= uint64_t{1} << (v % 64);
        ++distinct;
      }
    }
    // A centre that gathered only its own view's points while a better compatible point of
    // another view lies within its radius: that point's cluster represents the place (the
    // seed is typically a mixed pixel off the surface, beyond the others' seed radius).
    if (distinct == 1 && ((flags[seeds[c]] & kOutranked) ||
                          pts.border[seeds[c]] < options.one_view_cluster_border_px)) {
      cluster[c].absorbed = 1;
      return;
    }
    cluster[c] = {static_cast<float>(si / sw), static_cast<float>(sq / sw),
                  static_cast<uint16_t>(distinct), 1, 0};
  });
  for (size_t c = 0; c < nc; ++c) {
    s.absorbed_clusters += cluster[c].absorbed;
    s.clusters += cluster[c].keep;
  }
  out.points.reserve(static_cast<size_t>(s.clusters));
  out.normals.reserve(static_cast<size_t>(s.clusters));
  out.intensity.reserve(static_cast<size_t>(s.clusters));
  out.quality.reserve(static_cast<size_t>(s.clusters));
  result->support.reserve(static_cast<size_t>(s.clusters));
  result->view.reserve(static_cast<size_t>(s.clusters));
  for (size_t c = 0; c < nc; ++c) {
    if (!cluster[c].keep) continue;
    out.points.push_back(centres.pos[c].cast<double>());
    out.normals.push_back(centres.nrm[c].cast<double>());
    out.intensity.push_back(cluster[c].intensity);
    out.quality.push_back(cluster[c].quality);
    result->support.push_back(cluster[c].distinct);
    result->view.push_back(pts.view[seeds[c]]);
  }
  std::vector<uint32_t> passed;
  for (size_t k = 0; k < pts.size(); ++k) {
    if (in_overlap[k] && assign[k] != kNone) continue;
    if (flags[k] & kAbsorbed) {
      ++s.absorbed;
      continue;
    }
    if (in_overlap[k]) {
      // Not a seed, so a compatible point of another view outranks it within its seed radius:
      // that better point represents the place.
      ++s.unassigned;
      continue;
    }
    if (pts.border[k] < options.border_trim_px) {
      ++s.trimmed;
      continue;
    }
    ++s.passed_through;
    passed.push_back(static_cast<uint32_t>(k));
  }
  const std::vector<float> offset =
      SingleCoverageOffsets(pts, grids, passed, options.smooth_radius_px, cos_max, &s);
  for (size_t m = 0; m < passed.size(); ++m) {
    const uint32_t k = passed[m];
    const FusionView& fv = views[pts.view[k]];
    const PointCloud& c = fv.cloud.cloud;
    const uint32_t i = pts.grid[k];
    const Eigen::Vector3d n = fv.world_from_sensor.RotateDirection(c.normals[i]);
    out.points.push_back(fv.world_from_sensor * c.points[i] + static_cast<double>(offset[m]) * n);
    out.normals.push_back(n);
    out.intensity.push_back(pts.intensity[k]);
    out.quality.push_back(pts.quality[k]);
    result->support.push_back(1);
    result->view.push_back(pts.view[k]);
  }
  out.colors.resize(out.size());
  for (size_t i = 0; i < out.size(); ++i) {
    const auto g = static_cast<uint8_t>(std::clamp(std::lround(out.intensity[i]), 0L, 255L));
    out.colors[i] = {g, g, g};
  }
  s.fused_points = static_cast<int64_t>(out.size());
  if (s.overlap_points == 0) {
    s.status = FusionStatus::kNoOverlap;
    s.message = util::StrCat(
        views.size() > 1 ? "no view overlaps another" : "one view", "; all points passed through",
        s.trimmed > 0 ? util::StrCat(" except ", s.trimmed, " lone border points (trimmed)")
                      : std::string());
  }
}

}  // namespace

FusionResult FuseViews(const std::vector<FusionView>& views, const FusionOptions& options) {
  options.Check();
  util::Timer timer;
  FusionResult result;
  FusionSummary& s = result.summary;
  s.views = static_cast<int>(views.size());
  if (views.empty()) return Fail(std::move(result), FusionStatus::kEmptyInput, "no views");
  if (views.size() > 65535) {
    return Fail(std::move(result), FusionStatus::kBadView, "more than 65535 views");
  }

  // Prepare: the views checked and measured, their points gathered, their grids indexed.
  Points pts;
  std::vector<ViewGrid> grids;
  std::vector<size_t> view_start;
  {
    ViewMeasures measures;
    std::optional<Refusal> refused = MeasureViews(views, options, &measures, &s);
    if (!refused) refused = GatherPoints(views, options, measures, &pts, &s);
    if (!refused) refused = BuildGrids(views, options, pts, &view_start, &grids, &s);
    if (refused) return Fail(std::move(result), refused->status, std::move(refused->message));
  }
  s.prepare_s = timer.ElapsedSeconds();

  util::Timer stage;
  const std::vector<uint8_t> flags = FindOverlap(pts, grids, view_start, options);
  std::vector<uint32_t> seeds;
  std::vector<uint8_t> in_overlap(pts.size(), 0);
  for (size_t k = 0; k < pts.size(); ++k) {
    in_overlap[k] = (flags[k] & kOverlap) != 0;
    s.overlap_points += in_overlap[k];
    if (flags[k] & kSeed) seeds.push_back(static_cast<uint32_t>(k));
  }
  result.overlap.resize(views.size());
  for (size_t v = 0; v < views.size(); ++v)
    result.overlap[v].assign(views[v].cloud.valid.size(), 0);
  for (size_t k = 0; k < pts.size(); ++k) result.overlap[pts.view[k]][pts.grid[k]] = in_overlap[k];
  s.overlap_s = stage.ElapsedSeconds();

  stage.Restart();
  // Travel: noise and registration error (half a median spacing + the registration term is
  // several noise sigmas on every rig measured), at most the seed radius.
  Centres centres = SeedCentres(pts, seeds, 0.5 * s.median_spacing_mm + RegistrationTerm(options));
  // Candidate centres of every overlap point, found once: centres move along their normals by
  // noise and registration error, a fraction of a spacing, and at most their travel, so the
  // centres within a point's radius at any iteration are among those whose seeds lie within
  // radius + the largest travel. Of those the kCandidates nearest are kept (ordered by seed
  // distance, then index: deterministic); the iterations then assign among them without a
  // search. Not initialized: only the overlap points' rows are written and read (the pages are
  // first touched by the parallel search, not cleared by one thread beforehand).
  const std::unique_ptr<int32_t[]> candidates(new int32_t[pts.size() * kCandidates]);
  FindCandidates(pts, grids, in_overlap, seeds, static_cast<float>(centres.max_travel_mm),
                 kCandidates, candidates.get());
  s.candidates_s = stage.ElapsedSeconds();

  stage.Restart();
  Membership membership;
  membership.assign.assign(pts.size(), kNone);
  membership.start.assign(seeds.size() + 1, 0);
  ClusterPoints(pts, in_overlap, seeds, candidates.get(), options, &centres, &membership, &s);
  // The last update moved the centres; the membership of that update defines the clusters.
  s.cluster_s = stage.ElapsedSeconds();

  stage.Restart();
  WriteFused(views, pts, grids, flags, in_overlap, seeds, centres, membership, options, &result);
  s.output_s = stage.ElapsedSeconds();

  s.time_s = timer.ElapsedSeconds();
  return result;
}

}  // namespace fringe::fusion
