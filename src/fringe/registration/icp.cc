#include "fringe/registration/icp.h"

#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <memory>
#include <nanoflann.hpp>
#include <numeric>
#include <random>

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
  std::string s = StrCat("icp: ", ToString(status), " in ", seconds, " s");
  for (const IcpLevelReport& l : levels) {
    s += StrCat("; level ", l.level, " (", l.points_per_view, " pts/view): ", l.iterations, " it",
                l.converged ? "" : " (not converged)", ", threshold ", l.threshold_start_mm, " -> ",
                l.threshold_end_mm, " mm, rms ", l.rms_start_mm, " -> ", l.rms_end_mm, " mm, ",
                l.correspondences, " pairs of points over ", l.overlapping_pairs, " view pairs, ",
                l.degenerate_directions, " degenerate directions, last step ",
                l.last_step_rotation_deg, " deg / ", l.last_step_translation_mm, " mm (",
                l.last_step_sigmas, " sigma)");
  }
  if (!message.empty()) s += ": " + message;
  return s;
}

namespace {

// nanoflann adaptor over a list of points (usable ones only).
struct PointsAdaptor {
  std::vector<Vector3d> pts;
  size_t kdtree_get_point_count() const { return pts.size(); }
  double kdtree_get_pt(size_t i, size_t d) const { return pts[i][static_cast<int>(d)]; }
  template <class B>
  bool kdtree_get_bbox(B&) const {
    return false;
  }
};
using KdTree =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, PointsAdaptor>,
                                        PointsAdaptor, 3, uint32_t>;

// Nearest neighbour within a radius, for nanoflann: the search starts with the radius as its
// worst distance, so branches beyond it are pruned (samples outside the overlap of two views,
// most of them, cost a few node visits instead of a full descent).
struct NearestWithin {
  explicit NearestWithin(double radius_sq) : d2(radius_sq) {}
  double d2;
  uint32_t index = 0;
  bool found = false;
  size_t size() const { return found ? 1 : 0; }
  bool full() const { return found; }
  bool addPoint(double dist, uint32_t i) {
    if (dist < d2) {
      d2 = dist;
      index = i;
      found = true;
    }
    return true;
  }
  double worstDist() const { return d2; }
};

struct PreparedView {
  PointsAdaptor data;             // usable points, sensor frame
  std::vector<Vector3d> normals;  // unit, sensor frame
  std::vector<uint32_t> order;    // seeded random order of the usable points
  std::unique_ptr<KdTree> tree;
};

struct Corr {
  int v = -1, u = -1;  // source view, target view
  Vector3d p_world = Vector3d::Zero(), q_world = Vector3d::Zero(), n_world = Vector3d::Zero();
  double r = 0;  // point-to-plane residual
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

namespace {}  // namespace

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
  // Prepare: usable points, seeded order, k-d trees.
  std::vector<PreparedView> prep(nv);
  tbb::parallel_for(0, nv, [&](int i) {
    const PointCloud* c = views[i].cloud;
    if (c == nullptr) return;
    PreparedView& pv = prep[i];
    for (size_t k = 0; k < c->size(); ++k) {
      if (k >= c->normals.size()) break;
      const Vector3d& p = c->points[k];
      const Vector3d& n = c->normals[k];
      if (!p.allFinite() || !n.allFinite() || std::abs(n.norm() - 1) > 1e-3) continue;
      pv.data.pts.push_back(p);
      pv.normals.push_back(n);
    }
    const uint64_t order_seed = options.seed * 1000003u + static_cast<uint64_t>(i);
    if (options.normal_space_sampling) {
      pv.order = NormalSpaceOrder(pv.normals, order_seed);
    } else {
      pv.order.resize(pv.data.pts.size());
      std::iota(pv.order.begin(), pv.order.end(), 0u);
      std::mt19937_64 rng(order_seed);
      std::shuffle(pv.order.begin(), pv.order.end(), rng);
    }
    if (!pv.data.pts.empty()) {
      pv.tree = std::make_unique<KdTree>(3, pv.data, nanoflann::KDTreeSingleIndexAdaptorParams(16));
    }
  });
  for (int i = 0; i < nv; ++i) {
    if (views[i].cloud == nullptr)
      throw Error(StrCat("RefineMultiView: view ", i, " has no cloud"));
    if (!views[i].cloud->has_normals()) {
      throw Error(StrCat("RefineMultiView: view ", i, " has no normals (estimate them first)"));
    }
    if (prep[i].data.pts.size() < 10) {
      throw Error(StrCat("RefineMultiView: view ", i, " has ", prep[i].data.pts.size(),
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
  std::vector<Rigid3d>& pose = result.world_from_sensor;
  const double cos_max = std::cos(options.max_normal_angle_deg * M_PI / 180);
  // One iteration at the schedule's sample count and threshold: associate every view's samples
  // with every other view, one simultaneous step of all free views.
  const auto iterate = [&](int points, double threshold, IcpLevelReport* rep) {
    IcpIteration out;
    std::vector<Corr> corr;
    int pairs_used = 0;
    std::vector<std::vector<double>> overlap(nv, std::vector<double>(nv, 0.0));
    for (int v = 0; v < nv; ++v) {
      const PreparedView& sv = prep[v];
      const int ns = std::min<int>(points, static_cast<int>(sv.order.size()));
      for (int u = 0; u < nv; ++u) {
        if (u == v || (block[v] < 0 && block[u] < 0)) continue;
        const Rigid3d u_from_v = pose[u].Inverse() * pose[v];
        // Neighbours are searched within the larger of the threshold and the first one: the
        // threshold bounds the point-to-plane distance, which falls below the sampling
        // spacing long before the Euclidean neighbour distance does.
        const double search = std::max(threshold, options.initial_threshold_mm);
        const double search_sq = search * search;
        const PreparedView& tv = prep[u];
        std::vector<Corr> found(ns);
        tbb::parallel_for(0, ns, [&](int s) {
          const uint32_t k = sv.order[s];
          const Vector3d q = u_from_v * sv.data.pts[k];
          NearestWithin rs(search_sq);
          tv.tree->findNeighbors(rs, q.data(), nanoflann::SearchParams());
          Corr& c = found[s];
          if (!rs.found) return;
          const uint32_t idx = rs.index;
          const Vector3d& nt = tv.normals[idx];
          if (u_from_v.RotateDirection(sv.normals[k]).dot(nt) < cos_max) return;
          c.v = v;
          c.u = u;
          c.p_world = pose[v] * sv.data.pts[k];
          c.q_world = pose[u] * tv.data.pts[idx];
          c.n_world = pose[u].RotateDirection(nt);
          c.r = c.n_world.dot(c.p_world - c.q_world);
          if (std::abs(c.r) > threshold) c.v = -1;
        });
        std::vector<Corr> kept;
        for (Corr& c : found) {
          if (c.v >= 0) kept.push_back(c);
        }
        if (kept.size() < std::max<size_t>(3, options.min_overlap_fraction * ns)) continue;
        // Trim the worst distances of this pair.
        std::vector<double> d;
        for (const Corr& c : kept) d.push_back(std::abs(c.r));
        const size_t keep_n = std::max<size_t>(3, std::floor(options.trim_fraction * d.size()));
        if (keep_n < d.size()) {
          std::nth_element(d.begin(), d.begin() + (keep_n - 1), d.end());
          const double cut = d[keep_n - 1];
          std::vector<Corr> trimmed;
          for (const Corr& c : kept) {
            if (std::abs(c.r) <= cut && trimmed.size() < keep_n) trimmed.push_back(c);
          }
          kept.swap(trimmed);
        }
        overlap[v][u] = static_cast<double>(kept.size()) / ns;
        ++pairs_used;
        corr.insert(corr.end(), kept.begin(), kept.end());
      }
    }
    if (corr.empty()) return out;
    out.overlap = true;
    double ss = 0;
    Vector3d centroid = Vector3d::Zero();
    out.residuals_mm.reserve(corr.size());
    for (const Corr& c : corr) {
      ss += c.r * c.r;
      centroid += c.p_world;
      out.residuals_mm.push_back(c.r);
    }
    centroid /= static_cast<double>(corr.size());
    out.rms_mm = std::sqrt(ss / corr.size());
    rep->points_per_view = points;
    rep->correspondences = static_cast<int>(corr.size());
    rep->overlapping_pairs = pairs_used;
    result.overlap = overlap;
    // Normal equations over the free views (serial sum: thread-count independent).
    const int dim = 6 * nfree;
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(dim, dim);
    Eigen::VectorXd g = Eigen::VectorXd::Zero(dim);
    for (const Corr& c : corr) {
      Eigen::Matrix<double, 6, 1> jv, ju;
      jv << (c.p_world - centroid).cross(c.n_world), c.n_world;
      ju << -(c.q_world - centroid).cross(c.n_world), -c.n_world;
      const int bv = block[c.v], bu = block[c.u];
      if (bv >= 0) {
        H.block<6, 6>(6 * bv, 6 * bv) += jv * jv.transpose();
        g.segment<6>(6 * bv) += jv * c.r;
      }
      if (bu >= 0) {
        H.block<6, 6>(6 * bu, 6 * bu) += ju * ju.transpose();
        g.segment<6>(6 * bu) += ju * c.r;
      }
      if (bv >= 0 && bu >= 0) {
        H.block<6, 6>(6 * bv, 6 * bu) += jv * ju.transpose();
        H.block<6, 6>(6 * bu, 6 * bv) += ju * jv.transpose();
      }
    }
    // A plane with a sphere on it leaves rotations about the sphere's vertical unconstrained;
    // noise and edge points would otherwise slide the views along such directions.
    double lever_sq = 0;
    for (const Corr& c : corr) lever_sq += (c.p_world - centroid).squaredNorm();
    const double lever = std::max(1.0, std::sqrt(lever_sq / corr.size()));
    const IcpStep step = DegeneracyAwareStep(H, g, lever, options.degeneracy_ratio, out.rms_mm);
    rep->degenerate_directions = step.degenerate;
    out.step_sigmas = step.step_sigmas;
    for (int i = 0; i < nv; ++i) {
      if (block[i] < 0) continue;
      const Vector3d w = step.delta.segment<3>(6 * block[i]);
      const Vector3d t = step.delta.segment<3>(6 * block[i] + 3);
      const double angle = w.norm();
      const Rigid3d rot = angle > 0 ? Rigid3d::FromAxisAngle(w / angle, angle) : Rigid3d();
      // P' = R (P - c) + c + t
      const Rigid3d moved(rot.rotation(), centroid + t - rot.RotateDirection(centroid));
      pose[i] = moved * pose[i];
      out.step_rotation_deg = std::max(out.step_rotation_deg, angle * 180 / M_PI);
      out.step_translation_mm =
          std::max(out.step_translation_mm, (moved * centroid - centroid).norm());
    }
    return out;
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
                                               double tolerance_mm, double max_normal_angle_deg,
                                               uint64_t seed) {
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
  usable(source, &src.data.pts, &src.normals);
  usable(target, &tgt.data.pts, &tgt.normals);
  std::vector<SurfaceAgreement> out(target_from_source.size());
  if (src.data.pts.empty() || tgt.data.pts.empty()) return out;
  const std::vector<uint32_t> order = NormalSpaceOrder(src.normals, seed);
  const int ns = std::min<int>(samples, static_cast<int>(order.size()));
  const KdTree tree(3, tgt.data, nanoflann::KDTreeSingleIndexAdaptorParams(16));
  const double cos_max = std::cos(max_normal_angle_deg * M_PI / 180);
  for (size_t h = 0; h < target_from_source.size(); ++h) {
    const Rigid3d& t = target_from_source[h];
    std::vector<int8_t> state(ns, 0);  // 0 outside the overlap, 1 consistent, 2 inconsistent
    tbb::parallel_for(0, ns, [&](int s) {
      const uint32_t k = order[s];
      const Vector3d q = t * src.data.pts[k];
      NearestWithin rs(overlap_radius_mm * overlap_radius_mm);
      tree.findNeighbors(rs, q.data(), nanoflann::SearchParams());
      if (!rs.found) return;
      const Vector3d& nt = tgt.normals[rs.index];
      const bool ok = std::abs(nt.dot(q - tgt.data.pts[rs.index])) <= tolerance_mm &&
                      t.RotateDirection(src.normals[k]).dot(nt) >= cos_max;
      state[s] = ok ? 1 : 2;
    });
    int in = 0, bad = 0;
    for (int8_t x : state) {
      in += x > 0;
      bad += x == 2;
    }
    out[h].in_overlap = in;
    out[h].overlap = ns > 0 ? static_cast<double>(in) / ns : 0.0;
    out[h].inconsistent = in > 0 ? static_cast<double>(bad) / in : 1.0;
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
