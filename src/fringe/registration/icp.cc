#include "fringe/registration/icp.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <random>
#include <unordered_map>

#include "fringe/geometry/point_index.h"
#include "fringe/util/error.h"
#include "fringe/util/timer.h"

namespace fringe::registration {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using util::StrCat;

void IcpOptions::Check() const {
  const char* o = "IcpOptions";
  IcpSchedule::Check(o);
  util::CheckOption(trim_fraction > 0 && trim_fraction <= 1, o, "trim_fraction", trim_fraction,
                    "must be in (0, 1]");
  util::CheckOption(max_normal_angle_deg > 0 && max_normal_angle_deg <= 180, o,
                    "max_normal_angle_deg", max_normal_angle_deg, "must be in (0, 180]");
  util::CheckOption(min_overlap_fraction >= 0 && min_overlap_fraction < 1, o,
                    "min_overlap_fraction", min_overlap_fraction, "must be in [0, 1)");
  util::CheckOption(sample_max_normal_spread_deg >= 0 && sample_max_normal_spread_deg < 180, o,
                    "sample_max_normal_spread_deg", sample_max_normal_spread_deg,
                    "must be in [0, 180)");
  util::CheckOption(sample_spread_neighbours >= 1, o, "sample_spread_neighbours",
                    sample_spread_neighbours, "must be >= 1");
  util::CheckOption(max_incidence_deg >= 0 && max_incidence_deg <= 90, o, "max_incidence_deg",
                    max_incidence_deg, "must be in [0, 90]");
  util::CheckOption(max_tangential_spacings >= 0, o, "max_tangential_spacings",
                    max_tangential_spacings, "must be >= 0");
  util::CheckOption(projective_from_level >= 0, o, "projective_from_level", projective_from_level,
                    "must be >= 0");
  util::CheckOption(projective_window_px >= 0, o, "projective_window_px", projective_window_px,
                    "must be >= 0");
  util::CheckOption(start_misalignment_mm >= 0, o, "start_misalignment_mm", start_misalignment_mm,
                    "must be >= 0");
  util::CheckOption(max_grid_fit_error_px > 0, o, "max_grid_fit_error_px", max_grid_fit_error_px,
                    "must be > 0");
  util::CheckOption(max_partners >= 0, o, "max_partners", max_partners, "must be >= 0");
}

ViewGrid IndexViewGrid(const OrganizedPointCloud& grid_in_sensor) {
  grid_in_sensor.CheckConsistent();
  ViewGrid g;
  g.projection = GridProjection::Fit(grid_in_sensor);
  g.slot_of_point.reserve(grid_in_sensor.NumValid());
  for (size_t i = 0; i < grid_in_sensor.valid.size(); ++i) {
    if (grid_in_sensor.valid[i]) g.slot_of_point.push_back(static_cast<uint32_t>(i));
  }
  return g;
}

const char* ToString(IcpStatus s) {
  switch (s) {
    case IcpStatus::kOk:
      return "ok";
    case IcpStatus::kNotConverged:
      return "not converged";
    case IcpStatus::kNoOverlap:
      return "no overlap";
  }
  return "?";
}

std::string IcpSummary::BriefReport() const {
  std::string s = StrCat("icp: ", ToString(status), " in ", seconds, " s, ", associated_pairs,
                         " of ", touching_pairs, " touching view pairs associated");
  for (const IcpLevelReport& l : levels) {
    s += StrCat("; level ", l.level, " (", l.points_per_view, " pts/view): ", l.iterations, " it",
                l.converged ? "" : " (not converged)", ", threshold ", l.threshold_start_mm, " -> ",
                l.threshold_end_mm, " mm, rms ", l.rms_start_mm, " -> ", l.rms_end_mm, " mm, ",
                l.correspondences, " pairs of points over ", l.overlapping_pairs, " of ",
                l.searched_pairs, " view pairs searched (", l.projective_pairs, " projective), ",
                l.degenerate_directions, " degenerate directions, last step ",
                l.last_step_rotation_deg, " deg / ", l.last_step_translation_mm, " mm (",
                l.last_step_sigmas, " sigma)");
  }
  if (!message.empty()) s += ": " + message;
  return s;
}

namespace {

// A list of points (usable ones only), in the view's cloud or in PreparedView's own copy.
struct PointsView {
  const Vector3d* pts = nullptr;
  size_t n = 0;
};

struct PreparedView {
  PointsView data;                    // usable points, sensor frame
  const Vector3d* normals = nullptr;  // unit, sensor frame
  // The usable points and normals when some of the cloud's are not; when all are, data and
  // normals point into the cloud (no copy of 48 bytes per point and view).
  std::vector<Vector3d> own_pts, own_normals;
  void Own() {
    data = {own_pts.data(), own_pts.size()};
    normals = own_normals.data();
  }
  std::vector<uint32_t> order;       // seeded random order of the usable points
  std::unique_ptr<PointIndex> tree;  // built when some level searches this view by k-d tree
  // Projective association (a grid that fits): per slot in grid order, its usable point's
  // coordinates (float, relative to slot_origin; NaN: no point) and index (-1: none), 16 bytes:
  // the window search reads a few contiguous bytes per row instead of an index and then a
  // point elsewhere (the search is bound by memory latency). Relative to a point of the view,
  // float resolves ~1e-5 mm: nearest-point choices change only between points that close; the
  // residuals stay double.
  struct Slot {
    float x, y, z;
    int32_t point;
  };
  const GridProjection* projection = nullptr;
  bool projective_from_start = false;  // see IcpOptions::start_misalignment_mm
  std::vector<Slot> slots;
  Vector3d slot_origin = Vector3d::Zero();
  // Squared tangential distance bound of correspondences onto this view (IcpOptions::
  // max_tangential_spacings), infinite when off.
  double max_tangential_sq = std::numeric_limits<double>::infinity();

  // Index of the usable point nearest to q (sensor frame) within sqrt(radius_sq): exact, k-d.
  int32_t NearestByTree(const Vector3d& q, double radius_sq) const {
    return static_cast<int32_t>(tree->NearestWithin(q, radius_sq));
  }
  // The same among the points of the (2w + 1)^2 slots around q's projection (row by row, the
  // first of equal distances: deterministic).
  // The grid row q's window is centred on, or -1 when NearestByProjection finds nothing
  // (the same tests).
  int RowOf(const Vector3d& q, int w) const {
    Eigen::Vector2f cr;
    if (!projection->Project(q.cast<float>(), &cr)) return -1;
    const float c0 = std::round(cr.x()), r0 = std::round(cr.y());
    if (!(c0 >= -w && c0 < projection->width() + w && r0 >= -w && r0 < projection->height() + w)) {
      return -1;
    }
    return std::clamp(static_cast<int>(r0), 0, projection->height() - 1);
  }
  int32_t NearestByProjection(const Vector3d& q, int w, double radius_sq) const {
    Eigen::Vector2f cr;
    if (!projection->Project(q.cast<float>(), &cr)) return -1;
    const int width = projection->width(), height = projection->height();
    const float c0 = std::round(cr.x()), r0 = std::round(cr.y());
    if (!(c0 >= -w && c0 < width + w && r0 >= -w && r0 < height + w)) return -1;
    const int c = static_cast<int>(c0), r = static_cast<int>(r0);
    const int rb = std::max(0, r - w), re = std::min(height - 1, r + w);
    const int cb = std::max(0, c - w), ce = std::min(width - 1, c + w);
    const Eigen::Vector3f ql = (q - slot_origin).cast<float>();
    int32_t best = -1;
    float best_d2 = static_cast<float>(radius_sq);
    for (int y = rb; y <= re; ++y) {
      const Slot* slot = slots.data() + static_cast<size_t>(y) * width + cb;
      for (int x = cb; x <= ce; ++x, ++slot) {
        const float dx = slot->x - ql.x(), dy = slot->y - ql.y(), dz = slot->z - ql.z();
        const float d2 = dx * dx + dy * dy + dz * dz;  // NaN for an empty slot: never < best
        if (d2 < best_d2) {
          best_d2 = d2;
          best = slot->point;
        }
      }
    }
    return best;
  }
};

// A correspondence: usable point k of the source view, point idx of the target view, the
// point-to-plane residual (idx < 0: none) and the pair in the world frame. The world positions
// are computed in the search, where the target's point and normal have just been read (a pass
// of their own afterwards re-read them at random); the per-pair search buffer stays in cache.
struct Match {
  int32_t k = 0, idx = -1;
  double r = 0;
  Vector3d p_world, q_world, n_world;
};
struct PairMatches {
  int v = -1, u = -1;         // source view, target view
  size_t begin = 0, end = 0;  // range in the iteration's kept matches
};

// Normal-space sampling (Rusinkiewicz & Levoy, "Efficient variants of the ICP algorithm",
// 3DIM 2001): the points are binned by normal direction (cube map, kNormalBins x kNormalBins
// cells per face) and the order takes one point of each non-empty bin in turn (seeded random
// within and across bins). On a plane-dominated scene a uniform sample is nearly all plate:
// the walls that fix the sliding directions are a few percent of it, fall under the trimming
// and the percentile threshold as soon as a view slides, and the view keeps sliding. Any prefix
// of this order holds every normal direction in proportion to its bins, not its area.
constexpr int kNormalBins = 4;

}  // namespace

std::vector<uint32_t> NormalSpaceOrder(const std::vector<Vector3d>& normals, uint64_t seed) {
  std::vector<std::vector<uint32_t>> bins(6 * kNormalBins * kNormalBins);
  for (size_t k = 0; k < normals.size(); ++k) {
    const Vector3d& n = normals[k];
    int axis = 0;
    n.cwiseAbs().maxCoeff(&axis);
    const int face = 2 * axis + (n[axis] < 0 ? 1 : 0);
    const double a = n[(axis + 1) % 3] / std::abs(n[axis]);  // in [-1, 1]
    const double b = n[(axis + 2) % 3] / std::abs(n[axis]);
    const int ia = std::clamp(static_cast<int>((a + 1) / 2 * kNormalBins), 0, kNormalBins - 1);
    const int ib = std::clamp(static_cast<int>((b + 1) / 2 * kNormalBins), 0, kNormalBins - 1);
    bins[(face * kNormalBins + ia) * kNormalBins + ib].push_back(static_cast<uint32_t>(k));
  }
  std::mt19937_64 rng(seed);
  std::vector<std::vector<uint32_t>*> live;
  for (auto& b : bins) {
    if (b.empty()) continue;
    std::shuffle(b.begin(), b.end(), rng);
    live.push_back(&b);
  }
  std::vector<uint32_t> order;
  order.reserve(normals.size());
  for (size_t round = 0; !live.empty(); ++round) {
    std::shuffle(live.begin(), live.end(), rng);
    std::vector<std::vector<uint32_t>*> next;
    for (auto* b : live) {
      order.push_back((*b)[round]);
      if (round + 1 < b->size()) next.push_back(b);
    }
    live.swap(next);
  }
  return order;
}

namespace {

// The views' clouds, normals and grids checked against each other (fringe::Error otherwise).
void CheckIcpViews(const std::vector<IcpView>& views) {
  for (int i = 0; i < static_cast<int>(views.size()); ++i) {
    const IcpView& v = views[i];
    if (v.cloud == nullptr) throw Error(StrCat("RefineMultiView: view ", i, " has no cloud"));
    if (!v.cloud->has_normals()) {
      throw Error(StrCat("RefineMultiView: view ", i, " has no normals (estimate them first)"));
    }
    if (v.grid == nullptr) continue;
    const size_t slots =
        static_cast<size_t>(v.grid->projection.width()) * v.grid->projection.height();
    if (v.grid->slot_of_point.size() != v.cloud->size()) {
      throw Error(StrCat("RefineMultiView: view ", i, "'s grid lists ",
                         v.grid->slot_of_point.size(), " slots for ", v.cloud->size(), " points"));
    }
    for (uint32_t s : v.grid->slot_of_point) {
      if (s >= slots) {
        throw Error(StrCat("RefineMultiView: view ", i, "'s grid has slot ", s, " outside its ",
                           v.grid->projection.width(), "x", v.grid->projection.height(), " grid"));
      }
    }
  }
}

// Prepare one view (RefineMultiView): its usable points, their seeded sampling order, its slot
// table for projective association and the k-d tree where a level searches by tree; view i
// seeds its order.
void PrepareView(const IcpView& view, int i, const IcpOptions& options, bool projective,
                 PreparedView* out) {
  const PointCloud* c = view.cloud;
  PreparedView& pv = *out;
  if (projective) pv.projection = &view.grid->projection;
  const size_t cn = std::min(c->size(), c->normals.size());
  // Grid views only: their sensor is known to sit at the origin (see max_incidence_deg).
  const double cos_incidence = options.max_incidence_deg > 0 && view.grid != nullptr
                                   ? std::cos(options.max_incidence_deg * M_PI / 180)
                                   : -2.0;
  const auto usable = [&](size_t k) {
    const Vector3d& p = c->points[k];
    const Vector3d& n = c->normals[k];
    return p.allFinite() && n.allFinite() && std::abs(n.norm() - 1) <= 1e-3 &&
           -n.dot(p) >= cos_incidence * p.norm();
  };
  std::vector<uint8_t> use(cn);
  size_t n_usable = 0;
  for (size_t k = 0; k < cn; ++k) n_usable += use[k] = usable(k);
  if (n_usable == c->size()) {
    pv.data = {c->points.data(), n_usable};
    pv.normals = c->normals.data();
  } else {
    pv.own_pts.reserve(n_usable);
    pv.own_normals.reserve(n_usable);
    for (size_t k = 0; k < cn; ++k) {
      if (!use[k]) continue;
      pv.own_pts.push_back(c->points[k]);
      pv.own_normals.push_back(c->normals[k]);
    }
    pv.Own();
  }
  if (projective && pv.data.n > 0) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    pv.slot_origin = pv.data.pts[0];
    pv.slots.assign(static_cast<size_t>(pv.projection->width()) * pv.projection->height(),
                    {nan, nan, nan, -1});
    int32_t j = 0;
    for (size_t k = 0; k < cn; ++k) {
      if (!use[k]) continue;
      const Eigen::Vector3f p = (pv.data.pts[j] - pv.slot_origin).cast<float>();
      pv.slots[view.grid->slot_of_point[k]] = {p.x(), p.y(), p.z(), j++};
    }
  }
  const uint64_t order_seed = options.seed * 1000003u + static_cast<uint64_t>(i);
  // The points samples may come from (see IcpOptions::sample_max_normal_spread_deg).
  std::vector<uint32_t> candidates;
  if (options.sample_max_normal_spread_deg > 0 && pv.data.n > 0) {
    pv.tree = std::make_unique<PointIndex>(pv.data.pts, pv.data.n);
    const double cos_spread = std::cos(options.sample_max_normal_spread_deg * M_PI / 180);
    const size_t k = std::min<size_t>(options.sample_spread_neighbours + 1, pv.data.n);
    std::vector<uint8_t> smooth(pv.data.n, 0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, pv.data.n, 4096),
                      [&](const tbb::blocked_range<size_t>& rg) {
                        std::vector<size_t> idx(k);
                        std::vector<double> d2(k);
                        for (size_t p = rg.begin(); p != rg.end(); ++p) {
                          const size_t found = pv.tree->Nearest(pv.data.pts[p], k, &idx, &d2);
                          bool ok = true;
                          for (size_t m = 0; m < found && ok; ++m) {
                            ok = pv.normals[idx[m]].dot(pv.normals[p]) >= cos_spread;
                          }
                          smooth[p] = ok;
                        }
                      });
    for (size_t p = 0; p < pv.data.n; ++p) {
      if (smooth[p]) candidates.push_back(static_cast<uint32_t>(p));
    }
  } else {
    candidates.resize(pv.data.n);
    std::iota(candidates.begin(), candidates.end(), 0u);
  }
  if (options.normal_space_sampling) {
    std::vector<Vector3d> cn(candidates.size());
    for (size_t m = 0; m < candidates.size(); ++m) cn[m] = pv.normals[candidates[m]];
    pv.order = NormalSpaceOrder(cn, order_seed);
    for (uint32_t& o : pv.order) o = candidates[o];
  } else {
    pv.order = std::move(candidates);
    std::mt19937_64 rng(order_seed);
    std::shuffle(pv.order.begin(), pv.order.end(), rng);
  }
  if (projective && options.start_misalignment_mm > 0 && pv.data.n > 0) {
    // The window [round(c) - w, round(c) + w] holds every slot within w - 0.5 px of c.
    const float reach = static_cast<float>(options.projective_window_px) - 0.5f;
    pv.projective_from_start = true;
    for (size_t k = 0; k < pv.data.n && pv.projective_from_start; k += 64) {
      GridProjection::Disc d;
      pv.projective_from_start =
          pv.projection->DiscOf(pv.data.pts[k].cast<float>(),
                                static_cast<float>(options.start_misalignment_mm), &d) &&
          d.radius_px <= reach;
    }
  }
  const bool needs_tree = !projective ||
                          (options.projective_from_level > 0 && !pv.projective_from_start) ||
                          options.max_tangential_spacings > 0;
  if (needs_tree && pv.data.n > 0 && !pv.tree) {
    pv.tree = std::make_unique<PointIndex>(pv.data.pts, pv.data.n);
  }
  if (options.max_tangential_spacings > 0 && pv.data.n > 1) {
    // The point spacing: the median nearest-neighbour distance of a seeded subset.
    std::vector<double> nn;
    std::vector<size_t> idx;
    std::vector<double> d2;
    const size_t stride = std::max<size_t>(1, pv.data.n / 1000);
    for (size_t p = 0; p < pv.data.n; p += stride) {
      if (pv.tree->Nearest(pv.data.pts[p], 2, &idx, &d2) == 2) nn.push_back(d2[1]);
    }
    if (!nn.empty()) {
      std::nth_element(nn.begin(), nn.begin() + nn.size() / 2, nn.end());
      const double t = options.max_tangential_spacings * std::sqrt(nn[nn.size() / 2]);
      pv.max_tangential_sq = t * t;
    }
  }
}

// The views each view is associated with (IcpOptions::max_partners), ascending: each view's
// usable points binned into world voxels at its starting pose; view u touches view v in every
// voxel of v with one of u's within one voxel. The voxel is at least twice the first threshold
// (a correspondence needs its points within the search radius, and the poses move by about the
// first threshold at most) and a 64th of the views' median extent (a few thousand voxels per
// view whatever the point count). The touches are counted per voxel over the views sharing its
// neighbourhood, not by testing all pairs; the N x N table of counts is ~4 MB at 1000 views.
std::vector<std::vector<int>> AssociatedPartners(const std::vector<PreparedView>& prep,
                                                 const std::vector<Rigid3d>& pose,
                                                 const IcpOptions& options, IcpSummary* summary) {
  const int nv = static_cast<int>(prep.size());
  if (nv == 2) {  // pairwise ICP: the one pair, no occupancy needed
    summary->touching_pairs = summary->associated_pairs = 1;
    return {{1}, {0}};
  }
  std::vector<double> extent(nv, 0.0);
  for (int v = 0; v < nv; ++v) {
    Eigen::AlignedBox3d box;
    for (size_t k = 0; k < prep[v].data.n; ++k) box.extend(prep[v].data.pts[k]);
    extent[v] = box.isEmpty() ? 0.0 : box.diagonal().norm();
  }
  std::vector<double> sorted = extent;
  std::nth_element(sorted.begin(), sorted.begin() + nv / 2, sorted.end());
  const double voxel = std::max(2 * options.initial_threshold_mm, sorted[nv / 2] / 64);
  // 21 bits per axis: +-1e6 voxels, far beyond any scene at this voxel size.
  const auto key = [](int64_t x, int64_t y, int64_t z) {
    constexpr int64_t kOff = int64_t{1} << 20, kMask = (int64_t{1} << 21) - 1;
    return ((x + kOff) & kMask) << 42 | ((y + kOff) & kMask) << 21 | ((z + kOff) & kMask);
  };
  std::vector<std::vector<Eigen::Vector3i>> cells(nv);
  tbb::parallel_for(0, nv, [&](int v) {
    const Matrix3d r = pose[v].rotation_matrix();
    const Vector3d t = pose[v].translation();
    std::vector<Eigen::Vector3i> c(prep[v].data.n);
    for (size_t k = 0; k < prep[v].data.n; ++k) {
      c[k] = ((r * prep[v].data.pts[k] + t) / voxel).array().floor().cast<int>();
    }
    const auto less = [](const Eigen::Vector3i& a, const Eigen::Vector3i& b) {
      return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
    };
    std::sort(c.begin(), c.end(), less);
    c.erase(std::unique(c.begin(), c.end()), c.end());
    cells[v] = std::move(c);
  });
  std::unordered_map<int64_t, std::vector<int>> views_in;
  for (int v = 0; v < nv; ++v) {
    for (const Eigen::Vector3i& c : cells[v]) views_in[key(c.x(), c.y(), c.z())].push_back(v);
  }
  // touches[v][u]: voxels of v with one of u's within one voxel.
  std::vector<std::vector<int>> touches(nv, std::vector<int>(nv, 0));
  tbb::parallel_for(0, nv, [&](int v) {
    std::vector<size_t> stamp(nv, 0);
    size_t cell_no = 0;
    for (const Eigen::Vector3i& c : cells[v]) {
      ++cell_no;
      for (int dx = -1; dx <= 1; ++dx) {
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dz = -1; dz <= 1; ++dz) {
            const auto it = views_in.find(key(c.x() + dx, c.y() + dy, c.z() + dz));
            if (it == views_in.end()) continue;
            for (int u : it->second) {
              if (u == v || stamp[u] == cell_no) continue;
              stamp[u] = cell_no;
              ++touches[v][u];
            }
          }
        }
      }
    }
  });
  std::vector<std::vector<uint8_t>> keep(nv, std::vector<uint8_t>(nv, 0));
  for (int v = 0; v < nv; ++v) {
    std::vector<int> by_touch;
    for (int u = 0; u < nv; ++u) {
      if (touches[v][u] > 0) by_touch.push_back(u);
    }
    // The most touching first, the lower index among equals (deterministic).
    std::stable_sort(by_touch.begin(), by_touch.end(),
                     [&](int a, int b) { return touches[v][a] > touches[v][b]; });
    if (options.max_partners > 0 && static_cast<int>(by_touch.size()) > options.max_partners) {
      by_touch.resize(options.max_partners);
    }
    for (int u : by_touch) keep[v][u] = keep[u][v] = 1;
  }
  std::vector<std::vector<int>> partners(nv);
  summary->touching_pairs = summary->associated_pairs = 0;
  for (int v = 0; v < nv; ++v) {
    for (int u = 0; u < nv; ++u) {
      if (keep[v][u]) partners[v].push_back(u);
      if (u > v) {
        summary->touching_pairs += touches[v][u] > 0 || touches[u][v] > 0;
        summary->associated_pairs += keep[v][u];
      }
    }
  }
  return partners;
}

// One multi-view ICP problem (RefineMultiView): the prepared views, their unknown blocks (-1:
// fixed), the poses it moves, and the buffers every iteration reuses (a fresh vector per pair
// and iteration was page faults).
struct MultiViewIcp {
  MultiViewIcp(const IcpOptions& o, const std::vector<PreparedView>& views,
               const std::vector<std::vector<int>>& partner_lists, const std::vector<int>& blocks,
               int free_views, std::vector<Rigid3d>* poses,
               std::vector<std::vector<double>>* overlap)
      : options(o),
        prep(views),
        partners(partner_lists),
        block(blocks),
        nfree(free_views),
        pose(*poses),
        overlap_out(overlap) {}
  const IcpOptions& options;
  const std::vector<PreparedView>& prep;
  const std::vector<std::vector<int>>& partners;  // per view, ascending (AssociatedPartners)
  const std::vector<int>& block;
  int nfree = 0;
  std::vector<Rigid3d>& pose;
  std::vector<std::vector<double>>* overlap_out;
  int nv = static_cast<int>(prep.size());
  double cos_max = std::cos(options.max_normal_angle_deg * M_PI / 180);
  std::vector<Match> found, kept;
  std::vector<int> row_of, row_start, visit;  // the search order of a pair's samples
  std::vector<PairMatches> pairs;
  std::vector<double> dist;
  // Per view, the samples of the current level in ascending point order (the grid order of a
  // compacted view): the association then walks both clouds nearly sequentially instead of
  // missing the cache on every sample (the loop is memory-bound).
  std::vector<std::vector<uint32_t>> samples = std::vector<std::vector<uint32_t>>(nv);
  // The samples' points and normals gathered in that order: the loop reads them sequentially.
  std::vector<std::vector<Vector3d>> sample_pts = std::vector<std::vector<Vector3d>>(nv);
  std::vector<std::vector<Vector3d>> sample_normals = std::vector<std::vector<Vector3d>>(nv);
  int samples_points = -1;

  // One iteration at the schedule's sample count and threshold: associate every view's samples
  // with its partners, one simultaneous step of all free views.
  IcpIteration Iterate(int points, double threshold, IcpLevelReport* rep) {
    IcpIteration out;
    kept.clear();
    pairs.clear();
    int projective_pairs = 0, searched_pairs = 0;
    std::vector<std::vector<double>> overlap(nv, std::vector<double>(nv, 0.0));
    const bool projective_level = rep->level >= options.projective_from_level;
    GatherSamples(points);
    for (int v = 0; v < nv; ++v) {
      for (int u : partners[v]) {
        if (block[v] < 0 && block[u] < 0) continue;
        if (block[v] < 0 && !options.sample_fixed_views) continue;
        ++searched_pairs;
        bool projective = false;
        if (AssociatePair(v, u, threshold, projective_level, &overlap, &projective)) {
          projective_pairs += projective;
        }
      }
    }
    rep->searched_pairs = searched_pairs;
    if (kept.empty()) return out;
    out.overlap = true;
    double ss = 0;
    Vector3d centroid = Vector3d::Zero();
    out.residuals_mm.reserve(kept.size());
    for (size_t i = 0; i < kept.size(); ++i) {
      ss += kept[i].r * kept[i].r;
      centroid += kept[i].p_world;
      out.residuals_mm.push_back(kept[i].r);
    }
    centroid /= static_cast<double>(kept.size());
    out.rms_mm = std::sqrt(ss / kept.size());
    rep->points_per_view = points;
    rep->correspondences = static_cast<int>(kept.size());
    rep->overlapping_pairs = static_cast<int>(pairs.size());
    rep->projective_pairs = projective_pairs;
    *overlap_out = overlap;
    Step(centroid, &out, rep);
    return out;
  }

  // The samples of `points` per view in ascending point order with their points and normals
  // (rebuilt when the level's sample count changes).
  void GatherSamples(int points) {
    if (samples_points == points) return;
    for (int v = 0; v < nv; ++v) {
      const PreparedView& sv = prep[v];
      const int ns = std::min<int>(points, static_cast<int>(sv.order.size()));
      samples[v].assign(sv.order.begin(), sv.order.begin() + ns);
      std::sort(samples[v].begin(), samples[v].end());
      sample_pts[v].resize(ns);
      sample_normals[v].resize(ns);
      for (int s = 0; s < ns; ++s) {
        sample_pts[v][s] = sv.data.pts[samples[v][s]];
        sample_normals[v][s] = sv.normals[samples[v][s]];
      }
    }
    samples_points = points;
  }

  // Associates view v's samples with view u (within the threshold, normals compatible,
  // tangentially close, the worst trimmed) into kept and pairs; false when too few remain.
  bool AssociatePair(int v, int u, double threshold, bool projective_level,
                     std::vector<std::vector<double>>* overlap, bool* projective_out) {
    const std::vector<uint32_t>& sample = samples[v];
    const int ns = static_cast<int>(sample.size());
    const std::vector<Vector3d>&sp = sample_pts[v], &sn = sample_normals[v];
    // Rotation matrices: a quaternion rotates a vector at several times the cost.
    const Rigid3d u_from_v_pose = pose[u].Inverse() * pose[v];
    const Matrix3d r_uv = u_from_v_pose.rotation_matrix();
    const Vector3d t_uv = u_from_v_pose.translation();
    const Matrix3d r_u = pose[u].rotation_matrix();
    const Vector3d t_u = pose[u].translation();
    // Neighbours are searched within the larger of the threshold and the first one: the
    // threshold bounds the point-to-plane distance, which falls below the sampling
    // spacing long before the Euclidean neighbour distance does.
    const double search = std::max(threshold, options.initial_threshold_mm);
    const double search_sq = search * search;
    const PreparedView& tv = prep[u];
    const bool projective =
        tv.projection != nullptr && (projective_level || tv.projective_from_start);
    const int w = options.projective_window_px;
    found.resize(ns);
    for (Match& m : found) m.idx = -1;
    // Projectively, the samples are searched in the order of the target rows they fall on
    // (a counting sort): the windows then slide down the target's grid, each row read
    // from memory about once, instead of jumping across ~20 MB of slots per sample. Each
    // sample's search is the same whatever the order; those that fall outside the grid
    // are not searched at all.
    int n_visit = ns;
    if (projective) {
      const int height = tv.projection->height();
      row_of.resize(ns);
      tbb::parallel_for(tbb::blocked_range<int>(0, ns, 1024),
                        [&](const tbb::blocked_range<int>& rg) {
                          for (int s = rg.begin(); s != rg.end(); ++s) {
                            row_of[s] = tv.RowOf(r_uv * sp[s] + t_uv, w);
                          }
                        });
      row_start.assign(height + 1, 0);
      for (int s = 0; s < ns; ++s) {
        if (row_of[s] >= 0) ++row_start[row_of[s] + 1];
      }
      for (int y = 0; y < height; ++y) row_start[y + 1] += row_start[y];
      n_visit = row_start[height];
      visit.resize(n_visit);
      for (int s = 0; s < ns; ++s) {
        if (row_of[s] >= 0) visit[row_start[row_of[s]]++] = s;
      }
    } else {
      visit.resize(ns);
      std::iota(visit.begin(), visit.end(), 0);
    }
    tbb::parallel_for(tbb::blocked_range<int>(0, n_visit, 256),
                      [&](const tbb::blocked_range<int>& rg) {
                        for (int t = rg.begin(); t != rg.end(); ++t) {
                          const int s = visit[t];
                          Match& m = found[s];
                          const Vector3d q = r_uv * sp[s] + t_uv;
                          const int32_t idx = projective ? tv.NearestByProjection(q, w, search_sq)
                                                         : tv.NearestByTree(q, search_sq);
                          if (idx < 0) continue;
                          const Vector3d& nt = tv.normals[idx];
                          if ((r_uv * sn[s]).dot(nt) < cos_max) continue;
                          // Point-to-plane distance in the target's frame (the same in the
                          // world's).
                          const Vector3d& pt = tv.data.pts[idx];
                          const double r = nt.dot(q - pt);
                          if (std::abs(r) > threshold) continue;
                          if ((q - pt - r * nt).squaredNorm() > tv.max_tangential_sq) continue;
                          m.k = static_cast<int32_t>(sample[s]);
                          m.idx = idx;
                          m.r = r;
                          m.p_world = r_u * q + t_u;
                          m.q_world = r_u * pt + t_u;
                          m.n_world = r_u * nt;
                        }
                      });
    const size_t begin = kept.size();
    for (const Match& m : found) {
      if (m.idx >= 0) kept.push_back(m);
    }
    const size_t n_kept = kept.size() - begin;
    if (n_kept < std::max<size_t>(3, options.min_overlap_fraction * ns)) {
      kept.resize(begin);
      return false;
    }
    // Trim the worst distances of this pair.
    const size_t keep_n = std::max<size_t>(3, std::floor(options.trim_fraction * n_kept));
    if (keep_n < n_kept) {
      dist.clear();
      for (size_t i = begin; i < kept.size(); ++i) dist.push_back(std::abs(kept[i].r));
      std::nth_element(dist.begin(), dist.begin() + (keep_n - 1), dist.end());
      const double cut = dist[keep_n - 1];
      size_t out_i = begin;
      for (size_t i = begin; i < kept.size(); ++i) {
        if (std::abs(kept[i].r) <= cut && out_i - begin < keep_n) kept[out_i++] = kept[i];
      }
      kept.resize(out_i);
    }
    (*overlap)[v][u] = static_cast<double>(kept.size() - begin) / ns;
    *projective_out = projective;
    pairs.push_back({v, u, begin, kept.size()});
    return true;
  }

  // One simultaneous Gauss-Newton step of all free views over the kept correspondences, about
  // their centroid (degeneracy-aware: directions the overlap does not constrain are held).
  void Step(const Vector3d& centroid, IcpIteration* out, IcpLevelReport* rep) {
    // Normal equations over the free views, summed per view pair over fixed chunks in parallel,
    // the chunks added in order: the same sums for any thread count.
    const int dim = 6 * nfree;
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(dim, dim);
    Eigen::VectorXd g = Eigen::VectorXd::Zero(dim);
    double lever_sq = 0;
    using Mat6 = Eigen::Matrix<double, 6, 6>;
    using Vec6 = Eigen::Matrix<double, 6, 1>;
    struct Sums {
      Mat6 hvv = Mat6::Zero(), huu = Mat6::Zero(), hvu = Mat6::Zero();
      Vec6 gv = Vec6::Zero(), gu = Vec6::Zero();
      double lever_sq = 0;
    };
    constexpr size_t kChunk = 4096;
    for (const PairMatches& pm : pairs) {
      const int bv = block[pm.v], bu = block[pm.u];
      const size_t chunks = (pm.end - pm.begin + kChunk - 1) / kChunk;
      std::vector<Sums> sums(chunks);
      tbb::parallel_for(size_t{0}, chunks, [&](size_t ch) {
        Sums& su = sums[ch];
        const size_t e = std::min(pm.end, pm.begin + (ch + 1) * kChunk);
        for (size_t i = pm.begin + ch * kChunk; i < e; ++i) {
          const Match& c = kept[i];
          const double r = c.r;
          Vec6 jv, ju;
          jv << (c.p_world - centroid).cross(c.n_world), c.n_world;
          ju << -(c.q_world - centroid).cross(c.n_world), -c.n_world;
          if (bv >= 0) {
            su.hvv.noalias() += jv * jv.transpose();
            su.gv += jv * r;
          }
          if (bu >= 0) {
            su.huu.noalias() += ju * ju.transpose();
            su.gu += ju * r;
          }
          if (bv >= 0 && bu >= 0) su.hvu.noalias() += jv * ju.transpose();
          su.lever_sq += (c.p_world - centroid).squaredNorm();
        }
      });
      for (const Sums& su : sums) {
        if (bv >= 0) {
          H.block<6, 6>(6 * bv, 6 * bv) += su.hvv;
          g.segment<6>(6 * bv) += su.gv;
        }
        if (bu >= 0) {
          H.block<6, 6>(6 * bu, 6 * bu) += su.huu;
          g.segment<6>(6 * bu) += su.gu;
        }
        if (bv >= 0 && bu >= 0) {
          H.block<6, 6>(6 * bv, 6 * bu) += su.hvu;
          H.block<6, 6>(6 * bu, 6 * bv) += su.hvu.transpose();
        }
        lever_sq += su.lever_sq;
      }
    }
    // A plane with a sphere on it leaves rotations about the sphere's vertical unconstrained;
    // noise and edge points would otherwise slide the views along such directions.
    const double lever = std::max(1.0, std::sqrt(lever_sq / kept.size()));
    const IcpStep step = DegeneracyAwareStep(H, g, lever, options.degeneracy_ratio, out->rms_mm);
    rep->degenerate_directions = step.degenerate;
    out->step_sigmas = step.step_sigmas;
    for (int i = 0; i < nv; ++i) {
      if (block[i] < 0) continue;
      const Vector3d w = step.delta.segment<3>(6 * block[i]);
      const Vector3d t = step.delta.segment<3>(6 * block[i] + 3);
      const double angle = w.norm();
      const Rigid3d rot = angle > 0 ? Rigid3d::FromAxisAngle(w / angle, angle) : Rigid3d();
      // P' = R (P - c) + c + t
      const Rigid3d moved(rot.rotation(), centroid + t - rot.RotateDirection(centroid));
      pose[i] = moved * pose[i];
      out->step_rotation_deg = std::max(out->step_rotation_deg, angle * 180 / M_PI);
      out->step_translation_mm =
          std::max(out->step_translation_mm, (moved * centroid - centroid).norm());
    }
  }
};

}  // namespace

IcpResult RefineMultiView(const std::vector<IcpView>& views, const IcpOptions& options) {
  options.Check();
  util::Timer timer;
  const int nv = static_cast<int>(views.size());
  IcpResult result;
  result.overlap.assign(nv, std::vector<double>(nv, 0.0));
  for (const IcpView& v : views) result.world_from_sensor.push_back(v.world_from_sensor);
  if (nv < 2) {
    result.summary.status = IcpStatus::kNoOverlap;
    result.summary.message = "fewer than two views";
    return result;
  }
  CheckIcpViews(views);
  const int levels = static_cast<int>(options.points_per_level.size());
  const auto projective_view = [&](const IcpView& v) {
    return v.grid != nullptr && v.grid->projection.fitted() &&
           v.grid->projection.fit_error_px() <= options.max_grid_fit_error_px &&
           options.projective_from_level < levels;
  };
  std::vector<PreparedView> prep(nv);
  tbb::parallel_for(0, nv, [&](int i) {
    PrepareView(views[i], i, options, projective_view(views[i]), &prep[i]);
  });
  for (int i = 0; i < nv; ++i) {
    if (prep[i].data.n < 10) {
      throw Error(StrCat("RefineMultiView: view ", i, " has ", prep[i].data.n,
                         " points with normals; at least 10 are needed"));
    }
  }
  // Free views and their unknown blocks; with none fixed, view 0 holds the gauge.
  std::vector<int> block(nv, -1);
  bool any_fixed = false;
  for (const IcpView& v : views) any_fixed |= v.fixed;
  int nfree = 0;
  for (int i = 0; i < nv; ++i) {
    if (views[i].fixed || (!any_fixed && i == 0)) continue;
    block[i] = nfree++;
  }
  const std::vector<std::vector<int>> partners =
      AssociatedPartners(prep, result.world_from_sensor, options, &result.summary);
  MultiViewIcp problem(options, prep, partners, block, nfree, &result.world_from_sensor,
                       &result.overlap);
  const auto iterate = [&](int points, double threshold, IcpLevelReport* rep) {
    return problem.Iterate(points, threshold, rep);
  };
  const IcpScheduleOutcome outcome = RunIcpSchedule(options, iterate, &result.summary.levels);
  switch (outcome) {
    case IcpScheduleOutcome::kConverged:
      result.summary.status = IcpStatus::kOk;
      break;
    case IcpScheduleOutcome::kNotConverged:
      result.summary.status = IcpStatus::kNotConverged;
      result.summary.message = "a level stopped at its iteration limit";
      break;
    case IcpScheduleOutcome::kNoOverlap:
      result.summary.status = IcpStatus::kNoOverlap;
      result.summary.message = StrCat("no view pair has corresponding points within ",
                                      result.summary.levels.back().threshold_end_mm, " mm");
      break;
  }
  result.summary.seconds = timer.ElapsedSeconds();
  return result;
}

std::vector<SurfaceAgreement> MeasureAgreement(const PointCloud& source, const PointCloud& target,
                                               const std::vector<Rigid3d>& target_from_source,
                                               int samples, double overlap_radius_mm,
                                               double close_radius_mm, double tolerance_mm,
                                               double max_normal_angle_deg, uint64_t seed,
                                               bool normal_space) {
  const auto usable = [](const PointCloud& c, std::vector<Vector3d>* p, std::vector<Vector3d>* n) {
    for (size_t k = 0; k < c.size() && k < c.normals.size(); ++k) {
      if (!c.points[k].allFinite() || !c.normals[k].allFinite() ||
          std::abs(c.normals[k].norm() - 1) > 1e-3) {
        continue;
      }
      p->push_back(c.points[k]);
      n->push_back(c.normals[k]);
    }
  };
  PreparedView src, tgt;
  usable(source, &src.own_pts, &src.own_normals);
  usable(target, &tgt.own_pts, &tgt.own_normals);
  src.Own();
  tgt.Own();
  std::vector<SurfaceAgreement> out(target_from_source.size());
  if (src.data.n == 0 || tgt.data.n == 0) return out;
  std::vector<uint32_t> order;
  if (normal_space) {
    order = NormalSpaceOrder(src.own_normals, seed);
  } else {
    order.resize(src.own_pts.size());
    std::iota(order.begin(), order.end(), 0u);
    std::mt19937_64 rng(seed);
    std::shuffle(order.begin(), order.end(), rng);
  }
  const int ns = std::min<int>(samples, static_cast<int>(order.size()));
  const PointIndex tree(tgt.data.pts, tgt.data.n);
  const double cos_max = std::cos(max_normal_angle_deg * M_PI / 180);
  for (size_t h = 0; h < target_from_source.size(); ++h) {
    const Rigid3d& t = target_from_source[h];
    // 0 outside the overlap, 1 in the border band, 2 close and consistent, 3 close, inconsistent
    std::vector<int8_t> state(ns, 0);
    const double close_sq = close_radius_mm * close_radius_mm;
    tbb::parallel_for(0, ns, [&](int s) {
      const uint32_t k = order[s];
      const Vector3d q = t * src.data.pts[k];
      const int64_t nearest = tree.NearestWithin(q, overlap_radius_mm * overlap_radius_mm);
      if (nearest < 0) return;
      const Vector3d& pt = tgt.data.pts[nearest];
      if ((q - pt).squaredNorm() > close_sq) {
        state[s] = 1;
        return;
      }
      const Vector3d& nt = tgt.normals[nearest];
      const bool ok = std::abs(nt.dot(q - pt)) <= tolerance_mm &&
                      t.RotateDirection(src.normals[k]).dot(nt) >= cos_max;
      state[s] = ok ? 2 : 3;
    });
    int in = 0, close = 0, bad = 0, good = 0;
    for (int8_t x : state) {
      in += x > 0;
      close += x >= 2;
      good += x == 2;
      bad += x == 3;
    }
    out[h].in_overlap = in;
    out[h].close = close;
    out[h].overlap = ns > 0 ? static_cast<double>(in) / ns : 0.0;
    out[h].consistent = ns > 0 ? static_cast<double>(good) / ns : 0.0;
    out[h].inconsistent = close > 0 ? static_cast<double>(bad) / close : 1.0;
  }
  return out;
}

IcpResult AlignPointToPlane(const PointCloud& source, const PointCloud& target,
                            const Rigid3d& target_from_source, const IcpOptions& options) {
  IcpView t;
  t.cloud = &target;
  t.fixed = true;
  IcpView s;
  s.cloud = &source;
  s.world_from_sensor = target_from_source;
  IcpResult r = RefineMultiView({t, s}, options);
  return r;
}

}  // namespace fringe::registration
