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
  util::CheckOption(!points_per_level.empty(), o, "points_per_level", points_per_level.size(),
                    "needs at least one level");
  for (int n : points_per_level) {
    util::CheckOption(n >= 10, o, "points_per_level", n, "every level needs >= 10 points");
  }
  util::CheckOption(max_iterations_per_level >= 1, o, "max_iterations_per_level",
                    max_iterations_per_level, "must be >= 1");
  util::CheckOption(initial_threshold_mm > 0, o, "initial_threshold_mm", initial_threshold_mm,
                    "must be > 0");
  util::CheckOption(min_threshold_mm > 0 && min_threshold_mm <= initial_threshold_mm, o,
                    "min_threshold_mm", min_threshold_mm, "must be in (0, initial_threshold_mm]");
  util::CheckOption(shrink_factor > 0, o, "shrink_factor", shrink_factor, "must be > 0");
  util::CheckOption(shrink_percentile > 0 && shrink_percentile <= 1, o, "shrink_percentile",
                    shrink_percentile, "must be in (0, 1]");
  util::CheckOption(trim_fraction > 0 && trim_fraction <= 1, o, "trim_fraction", trim_fraction,
                    "must be in (0, 1]");
  util::CheckOption(max_normal_angle_deg > 0 && max_normal_angle_deg <= 180, o,
                    "max_normal_angle_deg", max_normal_angle_deg, "must be in (0, 180]");
  util::CheckOption(min_overlap_fraction >= 0 && min_overlap_fraction < 1, o,
                    "min_overlap_fraction", min_overlap_fraction, "must be in [0, 1)");
  util::CheckOption(degeneracy_ratio >= 0 && degeneracy_ratio < 1, o, "degeneracy_ratio",
                    degeneracy_ratio, "must be in [0, 1)");
  util::CheckOption(convergence_rotation_deg > 0, o, "convergence_rotation_deg",
                    convergence_rotation_deg, "must be > 0");
  util::CheckOption(convergence_translation_mm > 0, o, "convergence_translation_mm",
                    convergence_translation_mm, "must be > 0");
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
                l.degenerate_directions, " degenerate directions");
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
  double dist = 0;  // Euclidean distance
  double r = 0;     // point-to-plane residual
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
  double threshold = options.initial_threshold_mm;
  bool all_converged = true;

  for (size_t level = 0; level < options.points_per_level.size(); ++level) {
    IcpLevelReport rep;
    rep.level = static_cast<int>(level);
    rep.points_per_view = options.points_per_level[level];
    rep.threshold_start_mm = threshold;
    std::vector<double> last_dists;
    std::vector<float> last_signed;
    for (int it = 0; it < options.max_iterations_per_level; ++it) {
      // Samples of every view in the world frame at the current poses.
      std::vector<Corr> corr;
      std::vector<double> dists;
      int pairs_used = 0;
      std::vector<std::vector<double>> overlap(nv, std::vector<double>(nv, 0.0));
      for (int v = 0; v < nv; ++v) {
        const PreparedView& sv = prep[v];
        const int ns = std::min<int>(rep.points_per_view, static_cast<int>(sv.order.size()));
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
            const double d2 = rs.d2;
            const Vector3d& nt = tv.normals[idx];
            if (u_from_v.RotateDirection(sv.normals[k]).dot(nt) < cos_max) return;
            c.v = v;
            c.u = u;
            c.p_world = pose[v] * sv.data.pts[k];
            c.q_world = pose[u] * tv.data.pts[idx];
            c.n_world = pose[u].RotateDirection(nt);
            c.dist = std::sqrt(d2);
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
          for (const Corr& c : kept) {
            dists.push_back(std::abs(c.r));
            corr.push_back(c);
          }
        }
      }
      if (corr.empty()) {
        result.summary.status = IcpStatus::kNoOverlap;
        result.summary.message =
            StrCat("no view pair has corresponding points within ", threshold, " mm");
        result.summary.seconds = timer.ElapsedSeconds();
        result.summary.levels.push_back(rep);
        return result;
      }
      double ss = 0;
      Vector3d centroid = Vector3d::Zero();
      for (const Corr& c : corr) {
        ss += c.r * c.r;
        centroid += c.p_world;
      }
      centroid /= static_cast<double>(corr.size());
      const double rms = std::sqrt(ss / corr.size());
      if (it == 0) rep.rms_start_mm = rms;
      rep.rms_end_mm = rms;
      rep.correspondences = static_cast<int>(corr.size());
      rep.overlapping_pairs = pairs_used;
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
      // Degeneracy-aware step (Zhang, Kaess, Singh, "On degeneracy of optimization-based state
      // estimation problems", ICRA 2016): in the eigenbasis of the normal matrix (rotations
      // scaled by the correspondences' RMS lever so that all unknowns are lengths), directions
      // whose eigenvalue is below degeneracy_ratio x the largest are not moved. A plane with a
      // sphere on it leaves rotations about the sphere's vertical unconstrained; noise and
      // edge points would otherwise slide the views along such directions.
      double lever_sq = 0;
      for (const Corr& c : corr) lever_sq += (c.p_world - centroid).squaredNorm();
      const double lever = std::max(1.0, std::sqrt(lever_sq / corr.size()));
      Eigen::VectorXd scale = Eigen::VectorXd::Ones(dim);
      for (int b = 0; b < nfree; ++b) scale.segment<3>(6 * b).setConstant(1.0 / lever);
      const Eigen::MatrixXd Hs = scale.asDiagonal() * H * scale.asDiagonal();
      const Eigen::VectorXd gs = scale.cwiseProduct(g);
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(Hs);
      const double lmax = eig.eigenvalues().maxCoeff();
      Eigen::VectorXd ds = Eigen::VectorXd::Zero(dim);
      int degenerate = 0;
      for (int k = 0; k < dim; ++k) {
        const double l = eig.eigenvalues()[k];
        if (!(l > options.degeneracy_ratio * lmax)) {
          ++degenerate;
          continue;
        }
        ds += eig.eigenvectors().col(k) * (-eig.eigenvectors().col(k).dot(gs) / l);
      }
      rep.degenerate_directions = degenerate;
      const Eigen::VectorXd delta = scale.cwiseProduct(ds);
      double max_rot_deg = 0, max_trans_mm = 0;
      for (int i = 0; i < nv; ++i) {
        if (block[i] < 0) continue;
        const Vector3d w = delta.segment<3>(6 * block[i]);
        const Vector3d t = delta.segment<3>(6 * block[i] + 3);
        const double angle = w.norm();
        const Rigid3d rot = angle > 0 ? Rigid3d::FromAxisAngle(w / angle, angle) : Rigid3d();
        // P' = R (P - c) + c + t
        const Rigid3d step(rot.rotation(), centroid + t - rot.RotateDirection(centroid));
        pose[i] = step * pose[i];
        max_rot_deg = std::max(max_rot_deg, angle * 180 / M_PI);
        max_trans_mm = std::max(max_trans_mm, (step * centroid - centroid).norm());
      }
      if (options.shrink_within_level && !dists.empty()) {
        // Dynamic threshold after every iteration: min(previous, factor x percentile).
        std::vector<double> sorted = dists;
        const size_t q = std::min(sorted.size() - 1,
                                  static_cast<size_t>(options.shrink_percentile * sorted.size()));
        std::nth_element(sorted.begin(), sorted.begin() + q, sorted.end());
        threshold = std::max(options.min_threshold_mm,
                             std::min(threshold, options.shrink_factor * sorted[q]));
      }
      last_dists.swap(dists);
      last_signed.clear();
      const size_t stride = corr.size() / kReportedResiduals + 1;
      for (size_t k = 0; k < corr.size(); k += stride) {
        last_signed.push_back(static_cast<float>(corr[k].r));
      }
      rep.iterations = it + 1;
      if (max_rot_deg < options.convergence_rotation_deg &&
          max_trans_mm < options.convergence_translation_mm) {
        rep.converged = true;
        break;
      }
    }
    if (!last_dists.empty()) {
      std::vector<double> sorted = last_dists;
      std::sort(sorted.begin(), sorted.end());
      const auto at = [&](double q) {
        return sorted[std::min(sorted.size() - 1, static_cast<size_t>(q * sorted.size()))];
      };
      rep.residual_p50_mm = at(0.5);
      rep.residual_p90_mm = at(0.9);
      rep.residual_p99_mm = at(0.99);
    }
    rep.residuals_mm = std::move(last_signed);
    // Dynamic threshold, per level: min(previous, factor x percentile of the last residuals).
    // Shrinking it within a level would cut the correspondences that still carry the
    // misalignment (on a plane-dominated scene the percentile is the plate's noise while the
    // walls still see the view's slide) and the level would crawl instead of converging.
    if (!options.shrink_within_level && !last_dists.empty()) {
      const size_t q = std::min(last_dists.size() - 1,
                                static_cast<size_t>(options.shrink_percentile * last_dists.size()));
      std::nth_element(last_dists.begin(), last_dists.begin() + q, last_dists.end());
      threshold = std::max(options.min_threshold_mm,
                           std::min(threshold, options.shrink_factor * last_dists[q]));
    }
    rep.threshold_end_mm = threshold;
    all_converged &= rep.converged;
    result.summary.levels.push_back(rep);
  }
  result.summary.status = all_converged ? IcpStatus::kOk : IcpStatus::kNotConverged;
  if (!all_converged) {
    result.summary.message = "a level stopped at its iteration limit";
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
