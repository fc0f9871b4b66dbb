#include "fringe/registration/marker_matching.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include "fringe/geometry/align.h"
#include "fringe/util/error.h"

namespace fringe::registration {

using Eigen::Vector3d;
using util::StrCat;

void MarkerMatchOptions::Check() const {
  const char* o = "MarkerMatchOptions";
  util::CheckOption(distance_tolerance_mm > 0, o, "distance_tolerance_mm", distance_tolerance_mm,
                    "must be > 0");
  util::CheckOption(sigma_factor >= 0, o, "sigma_factor", sigma_factor, "must be >= 0");
  util::CheckOption(max_normal_angle_deg > 0 && max_normal_angle_deg <= 180, o,
                    "max_normal_angle_deg", max_normal_angle_deg, "must be in (0, 180]");
  util::CheckOption(min_matches >= 3, o, "min_matches", min_matches, "must be >= 3");
  util::CheckOption(ambiguity_margin >= 0, o, "ambiguity_margin", ambiguity_margin, "must be >= 0");
  util::CheckOption(same_pose_deg > 0, o, "same_pose_deg", same_pose_deg, "must be > 0");
  util::CheckOption(same_pose_mm > 0, o, "same_pose_mm", same_pose_mm, "must be > 0");
  util::CheckOption(outlier_rounds >= 0, o, "outlier_rounds", outlier_rounds, "must be >= 0");
}

const char* ToString(MarkerMatchStatus s) {
  switch (s) {
    case MarkerMatchStatus::kOk:
      return "ok";
    case MarkerMatchStatus::kTooFewMarkers:
      return "too few markers";
    case MarkerMatchStatus::kNoConsistentSet:
      return "no consistent set";
    case MarkerMatchStatus::kAmbiguous:
      return "ambiguous";
  }
  return "?";
}

std::string MarkerMatchResult::BriefReport() const {
  std::string s =
      StrCat("marker match: ", ToString(status), ", ", pairs.size(), " correspondences, rms ",
             rms_mm, " mm (", hypotheses, " hypotheses, runner-up ", runner_up_count, ")");
  if (!message.empty()) s += ": " + message;
  return s;
}

namespace {

// A three-marker hypothesis is kept when its fit RMS is at most this many times the RMS the
// markers' uncertainties predict (chi-square with 3 degrees of freedom: a right triple exceeds
// 2x in ~0.7 % of cases and then falls back to the marker-free path).
constexpr double kMinimalSetRmsFactor = 2.0;

struct Hypothesis {
  std::vector<std::pair<int, int>> pairs;  // verified
  Rigid3d map_from_view;
  double rms_mm = 0, max_mm = 0;
};

class Matcher {
 public:
  Matcher(const std::vector<MarkerPoint>& v, const std::vector<MarkerPoint>& m,
          const MarkerMatchOptions& o)
      : v_(v), m_(m), o_(o), n_(static_cast<int>(v.size())), nm_(static_cast<int>(m.size())) {
    dv_.resize(static_cast<size_t>(n_) * n_);
    dm_.resize(static_cast<size_t>(nm_) * nm_);
    for (int i = 0; i < n_; ++i)
      for (int j = 0; j < n_; ++j) dv_[i * n_ + j] = (v[i].centre - v[j].centre).norm();
    for (int a = 0; a < nm_; ++a)
      for (int b = 0; b < nm_; ++b) dm_[a * nm_ + b] = (m[a].centre - m[b].centre).norm();
  }

  double Tol(int i, int j, int a, int b) const {
    const double s2 =
        Sq(v_[i].sigma_mm) + Sq(v_[j].sigma_mm) + Sq(m_[a].sigma_mm) + Sq(m_[b].sigma_mm);
    return std::max(o_.distance_tolerance_mm, o_.sigma_factor * std::sqrt(s2));
  }
  double PointTol(int k, int c) const {
    return std::max(o_.distance_tolerance_mm,
                    o_.sigma_factor * std::sqrt(Sq(v_[k].sigma_mm) + Sq(m_[c].sigma_mm)));
  }

  // Grows a seed by distance consistency; returns the member pairs.
  std::vector<std::pair<int, int>> Grow(int i, int a, int j, int b) const {
    std::vector<std::pair<int, int>> set = {{i, a}, {j, b}};
    std::vector<char> used_v(n_, 0), used_m(nm_, 0);
    // worst[k * nm + c]: largest |distance difference| / tolerance of (k, c) to the members.
    std::vector<double> worst(static_cast<size_t>(n_) * nm_, 0.0);
    auto add = [&](int k0, int c0) {
      used_v[k0] = used_m[c0] = 1;
      for (int k = 0; k < n_; ++k) {
        if (used_v[k]) continue;
        for (int c = 0; c < nm_; ++c) {
          if (used_m[c]) continue;
          double& w = worst[k * nm_ + c];
          if (w > 1) continue;
          w = std::max(w, std::abs(dv_[k * n_ + k0] - dm_[c * nm_ + c0]) / Tol(k, k0, c, c0));
        }
      }
    };
    add(i, a);
    add(j, b);
    while (true) {
      double best = 1.0;
      int bk = -1, bc = -1;
      for (int k = 0; k < n_; ++k) {
        if (used_v[k]) continue;
        for (int c = 0; c < nm_; ++c) {
          if (used_m[c]) continue;
          const double w = worst[k * nm_ + c];
          if (w <= best) {
            if (w == best && bk >= 0) continue;
            best = w;
            bk = k;
            bc = c;
          }
        }
      }
      if (bk < 0) break;
      set.emplace_back(bk, bc);
      add(bk, bc);
    }
    return set;
  }

  // Weighted rigid fit with outlier rejection; false when degenerate.
  bool Fit(std::vector<std::pair<int, int>>* pairs, Rigid3d* t, double* rms, double* max) const {
    for (int round = 0; round <= o_.outlier_rounds; ++round) {
      if (static_cast<int>(pairs->size()) < 3) return false;
      std::vector<Vector3d> a, b;
      std::vector<double> w;
      for (const auto& [k, c] : *pairs) {
        a.push_back(v_[k].centre);
        b.push_back(m_[c].centre);
        w.push_back(1.0 / std::max(1e-12, Sq(v_[k].sigma_mm) + Sq(m_[c].sigma_mm)));
      }
      const RigidAlignment al = AlignRigid(a, b, w);
      if (!al.ok()) return false;
      *t = al.b_from_a;
      double ss = 0;
      std::vector<double> res(pairs->size());
      for (size_t q = 0; q < pairs->size(); ++q) {
        res[q] = (al.b_from_a * a[q] - b[q]).norm();
        ss += res[q] * res[q];
      }
      *rms = std::sqrt(ss / pairs->size());
      *max = *std::max_element(res.begin(), res.end());
      const double limit = std::max(3 * *rms, o_.distance_tolerance_mm);
      std::vector<std::pair<int, int>> kept;
      for (size_t q = 0; q < pairs->size(); ++q) {
        if (res[q] <= limit) kept.push_back((*pairs)[q]);
      }
      if (kept.size() == pairs->size() || round == o_.outlier_rounds) break;
      pairs->swap(kept);
    }
    return true;
  }

  // Gauss-Newton on sum r^T (R C_k R^T + C_c)^-1 r, r = R x_k + t - y_c, from the closed-form
  // fit (whose scalar weights cannot express the ray-direction uncertainty). Steps about the
  // pairs' centroid in the map frame; the weights follow the rotation.
  void RefineWithCovariances(const std::vector<std::pair<int, int>>& pairs, Rigid3d* t, double* rms,
                             double* max) const {
    const auto cov = [](const MarkerPoint& p) -> Eigen::Matrix3d {
      if (p.covariance.isZero(0)) return Eigen::Matrix3d::Identity() * Sq(p.sigma_mm) / 3;
      return p.covariance;
    };
    Vector3d centroid = Vector3d::Zero();
    for (const auto& [k, c] : pairs) centroid += m_[c].centre;
    centroid /= static_cast<double>(pairs.size());
    Rigid3d pose = *t;
    for (int it = 0; it < 10; ++it) {
      Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
      Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
      const Eigen::Matrix3d R = pose.rotation_matrix();
      for (const auto& [k, c] : pairs) {
        const Vector3d p = pose * v_[k].centre;
        const Vector3d r = p - m_[c].centre;
        const Eigen::Matrix3d C = R * cov(v_[k]) * R.transpose() + cov(m_[c]);
        const Eigen::Matrix3d W = C.inverse();
        if (!W.allFinite()) return;
        // d r / d (w, dt) for p' = p + w x (p - centroid) + dt.
        Eigen::Matrix<double, 3, 6> J;
        J.leftCols<3>() = -SkewOf(p - centroid);
        J.rightCols<3>().setIdentity();
        H += J.transpose() * W * J;
        g += J.transpose() * W * r;
      }
      const Eigen::Matrix<double, 6, 1> d = H.ldlt().solve(-g);
      if (!d.allFinite()) return;
      const Vector3d w = d.head<3>();
      const double angle = w.norm();
      const Rigid3d rot = angle > 0 ? Rigid3d::FromAxisAngle(w / angle, angle) : Rigid3d();
      pose = Rigid3d(rot.rotation(), centroid + d.tail<3>() - rot.RotateDirection(centroid)) * pose;
      if (angle < 1e-12 && d.tail<3>().norm() < 1e-9) break;
    }
    double ss = 0, mx = 0;
    for (const auto& [k, c] : pairs) {
      const double e = (pose * v_[k].centre - m_[c].centre).norm();
      ss += e * e;
      mx = std::max(mx, e);
    }
    *t = pose;
    *rms = std::sqrt(ss / pairs.size());
    *max = mx;
  }
  static Eigen::Matrix3d SkewOf(const Vector3d& v) {
    Eigen::Matrix3d s;
    s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
    return s;
  }

  // All view markers moved onto the map: nearest map marker within tolerance with compatible
  // normals, one to one (closest first).
  std::vector<std::pair<int, int>> Verify(const Rigid3d& map_from_view) const {
    const double cos_max = std::cos(o_.max_normal_angle_deg * M_PI / 180);
    struct Cand {
      double d;
      int k, c;
    };
    std::vector<Cand> cands;
    for (int k = 0; k < n_; ++k) {
      const Vector3d p = map_from_view * v_[k].centre;
      const Vector3d nv = map_from_view.RotateDirection(v_[k].normal);
      for (int c = 0; c < nm_; ++c) {
        const double d = (p - m_[c].centre).norm();
        if (d > PointTol(k, c)) continue;
        if (nv.squaredNorm() > 0.5 && m_[c].normal.squaredNorm() > 0.5 &&
            nv.dot(m_[c].normal) < cos_max) {
          continue;
        }
        cands.push_back({d, k, c});
      }
    }
    std::sort(cands.begin(), cands.end(), [](const Cand& x, const Cand& y) {
      return x.d != y.d ? x.d < y.d : (x.k != y.k ? x.k < y.k : x.c < y.c);
    });
    std::vector<char> uv(n_, 0), um(nm_, 0);
    std::vector<std::pair<int, int>> out;
    for (const Cand& c : cands) {
      if (uv[c.k] || um[c.c]) continue;
      uv[c.k] = um[c.c] = 1;
      out.emplace_back(c.k, c.c);
    }
    std::sort(out.begin(), out.end());
    return out;
  }

  MarkerMatchResult Run() const {
    MarkerMatchResult r;
    if (n_ < o_.min_matches || nm_ < o_.min_matches) {
      r.status = MarkerMatchStatus::kTooFewMarkers;
      r.message = StrCat(n_, " view markers, ", nm_, " map markers; ", o_.min_matches, " needed");
      return r;
    }
    std::vector<Hypothesis> hyps;
    std::set<std::pair<std::pair<int, int>, std::pair<int, int>>> explained;
    for (int i = 0; i < n_; ++i) {
      for (int j = i + 1; j < n_; ++j) {
        const double d = dv_[i * n_ + j];
        for (int a = 0; a < nm_; ++a) {
          for (int b = 0; b < nm_; ++b) {
            if (a == b || std::abs(dm_[a * nm_ + b] - d) > Tol(i, j, a, b)) continue;
            if (explained.count({{i, a}, {j, b}})) continue;
            std::vector<std::pair<int, int>> set = Grow(i, a, j, b);
            if (static_cast<int>(set.size()) < o_.min_matches) continue;
            Hypothesis h;
            if (!Fit(&set, &h.map_from_view, &h.rms_mm, &h.max_mm)) continue;
            h.pairs = Verify(h.map_from_view);
            if (static_cast<int>(h.pairs.size()) < o_.min_matches) continue;
            if (!Fit(&h.pairs, &h.map_from_view, &h.rms_mm, &h.max_mm)) continue;
            if (static_cast<int>(h.pairs.size()) < o_.min_matches) continue;
            // Three markers have no redundancy in their distances beyond the fit: any three are
            // congruent to their mirror image, and a chance triple of an unrelated or mirrored
            // layout agrees within the distance tolerance. Such a minimal set must fit as well as
            // the markers' uncertainties say (rms <= kMinimalSetRmsFactor x the expected).
            if (h.pairs.size() < 4) {
              double s2 = 0;
              for (const auto& [k, c] : h.pairs) s2 += Sq(v_[k].sigma_mm) + Sq(m_[c].sigma_mm);
              if (h.rms_mm > kMinimalSetRmsFactor * std::sqrt(s2 / h.pairs.size())) continue;
            }
            // Seeds inside this set would grow into the same hypothesis: skip them.
            for (const auto& p : h.pairs) {
              for (const auto& q : h.pairs) {
                if (p.first < q.first) explained.insert({p, q});
              }
            }
            AddHypothesis(&hyps, std::move(h));
          }
        }
      }
    }
    r.hypotheses = static_cast<int>(hyps.size());
    if (hyps.empty()) {
      r.status = MarkerMatchStatus::kNoConsistentSet;
      r.message = StrCat("no ", o_.min_matches,
                         " view markers share their mutual distances with "
                         "the map");
      return r;
    }
    size_t best = 0;
    for (size_t h = 1; h < hyps.size(); ++h) {
      if (Better(hyps[h], hyps[best])) best = h;
    }
    for (size_t h = 0; h < hyps.size(); ++h) {
      if (h == best) continue;
      r.runner_up_count = std::max(r.runner_up_count, static_cast<int>(hyps[h].pairs.size()));
    }
    Hypothesis& b = hyps[best];
    RefineWithCovariances(b.pairs, &b.map_from_view, &b.rms_mm, &b.max_mm);
    r.pairs = b.pairs;
    r.map_from_view = b.map_from_view;
    r.rms_mm = b.rms_mm;
    r.max_mm = b.max_mm;
    if (r.runner_up_count >= static_cast<int>(b.pairs.size()) - o_.ambiguity_margin) {
      r.status = MarkerMatchStatus::kAmbiguous;
      r.message = StrCat("two different poses fit ", b.pairs.size(), " and ", r.runner_up_count,
                         " markers (a symmetric layout); refused");
      r.pairs.clear();
      return r;
    }
    r.status = MarkerMatchStatus::kOk;
    return r;
  }

 private:
  static double Sq(double x) { return x * x; }
  static bool Better(const Hypothesis& x, const Hypothesis& y) {
    return x.pairs.size() != y.pairs.size() ? x.pairs.size() > y.pairs.size() : x.rms_mm < y.rms_mm;
  }
  void AddHypothesis(std::vector<Hypothesis>* hyps, Hypothesis h) const {
    for (Hypothesis& e : *hyps) {
      const RigidDifference d = Difference(e.map_from_view, h.map_from_view);
      if (d.angle_rad * 180 / M_PI < o_.same_pose_deg && d.translation_mm < o_.same_pose_mm) {
        if (Better(h, e)) e = std::move(h);
        return;
      }
    }
    hyps->push_back(std::move(h));
  }

  const std::vector<MarkerPoint>& v_;
  const std::vector<MarkerPoint>& m_;
  const MarkerMatchOptions& o_;
  int n_, nm_;
  std::vector<double> dv_, dm_;
};

}  // namespace

MarkerMatchResult MatchMarkers(const std::vector<MarkerPoint>& view_markers,
                               const std::vector<MarkerPoint>& map_markers,
                               const MarkerMatchOptions& options) {
  options.Check();
  for (const auto* list : {&view_markers, &map_markers}) {
    for (const MarkerPoint& p : *list) {
      if (!p.centre.allFinite() || !p.normal.allFinite() || !(p.sigma_mm > 0)) {
        throw Error("MatchMarkers: a marker has a non-finite centre or normal, or sigma <= 0");
      }
    }
  }
  return Matcher(view_markers, map_markers, options).Run();
}

}  // namespace fringe::registration
