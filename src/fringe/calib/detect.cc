#include "fringe/calib/detect.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <set>
#include <sstream>

#include <tbb/parallel_for.h>

#include "fringe/util/error.h"
#include "fringe/util/timer.h"

namespace fringe::calib {

void DetectionOptions::Check() const {
  using util::CheckOption;
  edges.Check();
  ellipse_fit.Check();
  const char* o = "DetectionOptions";
  CheckOption(min_radius_px > 0, o, "min_radius_px", min_radius_px, "must be > 0");
  CheckOption(max_radius_fraction > 0 && max_radius_fraction <= 1, o, "max_radius_fraction",
              max_radius_fraction, "must be in (0, 1]");
  CheckOption(min_axis_ratio > 0 && min_axis_ratio <= 1, o, "min_axis_ratio", min_axis_ratio,
              "must be in (0, 1]");
  CheckOption(min_convexity > 0 && min_convexity <= 1, o, "min_convexity", min_convexity,
              "must be in (0, 1]");
  CheckOption(max_fit_rms_px > 0, o, "max_fit_rms_px", max_fit_rms_px, "must be > 0");
  CheckOption(min_edge_coverage > 0 && min_edge_coverage <= 1, o, "min_edge_coverage",
              min_edge_coverage, "must be in (0, 1]");
  CheckOption(max_concentricity > 0, o, "max_concentricity", max_concentricity, "must be > 0");
  CheckOption(ring_ratio_tolerance > 0 && ring_ratio_tolerance < 1, o, "ring_ratio_tolerance",
              ring_ratio_tolerance, "must be in (0, 1)");
  CheckOption(threshold_levels >= 1 && threshold_levels <= 64, o, "threshold_levels",
              threshold_levels, "must be in [1, 64]");
  CheckOption(grid_tolerance > 0 && grid_tolerance <= 0.5, o, "grid_tolerance", grid_tolerance,
              "must be in (0, 0.5]");
  CheckOption(size_tolerance > 0 && size_tolerance < 1, o, "size_tolerance", size_tolerance,
              "must be in (0, 1)");
}

const char* DetectionStatusName(DetectionStatus s) {
  switch (s) {
    case DetectionStatus::kOk:
      return "ok";
    case DetectionStatus::kNotFound:
      return "not found";
    case DetectionStatus::kAmbiguous:
      return "ambiguous";
  }
  return "?";
}

std::string TargetDetection::BriefReport() const {
  std::ostringstream os;
  os << DetectionStatusName(status) << ": " << features.size() << " features, " << num_candidates
     << " candidates, " << rejected.size() << " rejected";
  if (!message.empty()) os << " (" << message << ")";
  return os.str();
}

namespace {

using Vec2 = Eigen::Vector2d;

constexpr const char* kHasHole = "has a hole (not a solid circle)";

Ellipse FromRotatedRect(const cv::RotatedRect& r) {
  Ellipse e;
  e.centre = {r.center.x, r.center.y};
  e.a = 0.5 * r.size.width;
  e.b = 0.5 * r.size.height;
  e.angle = r.angle * M_PI / 180;
  if (e.b > e.a) {
    std::swap(e.a, e.b);
    e.angle += M_PI / 2;
  }
  return e;
}

// A dark blob from one threshold level.
struct Blob {
  Ellipse outer;
  bool has_hole = false;
  Ellipse hole;
  int votes = 1;
};

struct Candidate {
  Ellipse outer, inner;
  std::vector<Vec2> outer_edge, inner_edge;
  Vec2 centre = Vec2::Zero();
  double size = 0;  // sqrt(a b) of the outer ellipse, px
  double fit_rms = 0;
  bool has_dot = false;
};

class Detector {
 public:
  // gray8: the 8-bit image for the blob search; fine: the same image at full precision on the
  // 0-255 scale (gray8 itself for 8-bit input) for the subpixel edges and intensities.
  Detector(const cv::Mat& gray8, const cv::Mat& fine, const CalibrationTarget& target,
           const DetectionOptions& options, TargetDetection* out)
      : gray_(gray8),
        target_(target),
        opt_(options),
        out_(out),
        gradient_(fine, options.edges.smoothing_sigma_px) {}

  void Run();
  // Blob finding, subpixel measurement and de-duplication (Run's first half): fills cands_.
  void FindCandidates();
  // The candidates as unordered observations (row = col = -1), in candidate order.
  std::vector<FeatureObservation> CandidateObservations() const;

 private:
  void FindBlobs(std::vector<Blob>* blobs);
  bool Refine(const Blob& blob, Candidate* cand, std::string* reason);
  bool MeasureEdges(const Ellipse& coarse, bool outward, double half_width,
                    std::vector<Vec2>* points, Ellipse* fitted, double* rms, std::string* reason);
  void Reject(const Vec2& c, const std::string& reason) {
    for (const auto& r : out_->rejected) {
      if ((r.centre_px - c).norm() < 3) return;
    }
    out_->rejected.push_back({c, reason});
  }
  // Grid growth from seeds (grid coords (row, col) -> candidate index).
  using GridMap = std::map<std::pair<int, int>, int>;
  void Grow(GridMap* grid, bool bounded, int max_extent) const;
  bool Order(GridMap* result);
  bool OrderByDistinctFeatures(GridMap* result);
  bool OrderCircleGrid(GridMap* result);
  bool OrientSymmetricGrid(const GridMap& best, GridMap* result);
  int OrderAsymmetric(const GridMap& grown, GridMap* result) const;
  void WarnAboutDeclaration();

  const cv::Mat& gray_;
  const CalibrationTarget& target_;
  const DetectionOptions& opt_;
  TargetDetection* out_;
  GradientImage gradient_;
  std::vector<Candidate> cands_;
};

void Detector::FindBlobs(std::vector<Blob>* blobs) {
  cv::Mat smooth;
  cv::GaussianBlur(gray_, smooth, cv::Size(5, 5), 1.0);
  // Thresholds spread between dark and bright percentiles.
  int hist[256] = {0};
  for (int r = 0; r < smooth.rows; ++r) {
    const uint8_t* p = smooth.ptr<uint8_t>(r);
    for (int c = 0; c < smooth.cols; ++c) ++hist[p[c]];
  }
  const double total = static_cast<double>(smooth.total());
  auto percentile = [&](double q) {
    double acc = 0;
    for (int i = 0; i < 256; ++i) {
      acc += hist[i];
      if (acc >= q * total) return i;
    }
    return 255;
  };
  const int lo = percentile(0.02), hi = percentile(0.98);
  const double min_r = opt_.min_radius_px;
  const double max_r = opt_.max_radius_fraction * std::min(gray_.cols, gray_.rows);
  const bool rings = target_.type == TargetType::kConcentricRings;
  const double ring_ratio = target_.inner_radius_mm / target_.outer_radius_mm;
  const int levels = opt_.threshold_levels;
  // Levels in parallel; blobs and rejections merged in level order (thread-count independent).
  std::vector<std::vector<Blob>> per_level(levels);
  std::vector<std::vector<RejectedCandidate>> level_rejects(levels);
  tbb::parallel_for(0, levels, [&](int level) {
    std::vector<Blob>& all = per_level[level];
    auto reject = [&](const Vec2& c, const char* why) {
      if (level == levels / 2) level_rejects[level].push_back({c, why});
    };
    const double t = lo + (hi - lo) * (level + 1.0) / (levels + 1.0);
    cv::Mat binary = smooth < t;
    std::vector<std::vector<cv::Point>> contours;
    std::vector<cv::Vec4i> hierarchy;
    cv::findContours(binary, contours, hierarchy, cv::RETR_TREE, cv::CHAIN_APPROX_NONE);
    std::vector<int> depth(contours.size(), 0);
    for (size_t i = 0; i < contours.size(); ++i) {
      int d = 0;
      for (int p = hierarchy[i][3]; p >= 0; p = hierarchy[p][3]) ++d;
      depth[i] = d;
    }
    for (size_t i = 0; i < contours.size(); ++i) {
      if (depth[i] % 2 != 0) continue;  // holes
      const auto& c = contours[i];
      const double area = cv::contourArea(c);
      if (area < M_PI * min_r * min_r || area > M_PI * max_r * max_r || c.size() < 8) continue;
      const cv::RotatedRect rr = cv::fitEllipse(c);
      const Ellipse e = FromRotatedRect(rr);
      const Vec2 centre = e.centre;
      if (!(e.b > 0) || !std::isfinite(e.a)) continue;
      std::vector<cv::Point> hull;
      cv::convexHull(c, hull);
      const double convexity = area / std::max(1e-9, cv::contourArea(hull));
      if (convexity < opt_.min_convexity) {
        reject(centre, "not convex");
        continue;
      }
      if (e.AxisRatio() < opt_.min_axis_ratio) {
        reject(centre, "too elongated (axis ratio)");
        continue;
      }
      const double fill = area / e.Area();
      if (fill < 0.8 || fill > 1.15) {
        reject(centre, "not an ellipse (area)");
        continue;
      }
      Blob blob;
      blob.outer = e;
      // Largest hole.
      int best_hole = -1;
      double hole_area = 0;
      for (int h = hierarchy[i][2]; h >= 0; h = hierarchy[h][0]) {
        const double ha = cv::contourArea(contours[h]);
        if (ha > hole_area) {
          hole_area = ha;
          best_hole = h;
        }
      }
      if (rings) {
        const double ratio = std::sqrt(hole_area / area);
        if (best_hole < 0 || contours[best_hole].size() < 6 ||
            std::abs(ratio / ring_ratio - 1) > opt_.ring_ratio_tolerance) {
          reject(centre, "no concentric hole of the ring's size");
          continue;
        }
        blob.hole = FromRotatedRect(cv::fitEllipse(contours[best_hole]));
        if ((blob.hole.centre - e.centre).norm() > opt_.max_concentricity * e.b) {
          reject(centre, "hole not concentric");
          continue;
        }
        blob.has_hole = true;
      } else if (hole_area > 0.05 * area) {
        reject(centre, kHasHole);
        continue;
      }
      all.push_back(blob);
    }
  });
  std::vector<Blob> all;
  for (int level = 0; level < levels; ++level) {
    all.insert(all.end(), per_level[level].begin(), per_level[level].end());
    for (const auto& r : level_rejects[level]) Reject(r.centre_px, r.reason);
  }
  // Merge the same blob seen at several levels: keep the member of median size.
  std::vector<bool> taken(all.size(), false);
  for (size_t i = 0; i < all.size(); ++i) {
    if (taken[i]) continue;
    std::vector<size_t> members{i};
    taken[i] = true;
    for (size_t j = i + 1; j < all.size(); ++j) {
      if (taken[j]) continue;
      const double d = (all[j].outer.centre - all[i].outer.centre).norm();
      const double s =
          std::sqrt(all[j].outer.a * all[j].outer.b) / std::sqrt(all[i].outer.a * all[i].outer.b);
      if (d < 0.3 * all[i].outer.b && s > 0.7 && s < 1.4) {
        members.push_back(j);
        taken[j] = true;
      }
    }
    std::sort(members.begin(), members.end(), [&](size_t a, size_t b) {
      return all[a].outer.a * all[a].outer.b < all[b].outer.a * all[b].outer.b;
    });
    Blob b = all[members[members.size() / 2]];
    b.votes = static_cast<int>(members.size());
    blobs->push_back(b);
  }
}

bool Detector::MeasureEdges(const Ellipse& coarse, bool outward, double half_width,
                            std::vector<Vec2>* points, Ellipse* fitted, double* rms,
                            std::string* reason) {
  const double circumference =
      M_PI * (3 * (coarse.a + coarse.b) -
              std::sqrt((3 * coarse.a + coarse.b) * (coarse.a + 3 * coarse.b)));
  const int n = std::clamp(static_cast<int>(circumference / 1.0), 24, 1440);
  EdgeOptions eo = opt_.edges;
  eo.search_half_width_px = half_width;
  points->clear();
  for (int k = 0; k < n; ++k) {
    const double t = 2 * M_PI * k / n;
    Vec2 normal = coarse.NormalAt(t);
    if (!outward) normal = -normal;
    const auto e = LocateEdge(gradient_, coarse.PointAt(t), normal, eo);
    if (e) points->push_back(e->position);
  }
  if (points->size() < opt_.min_edge_coverage * n) {
    *reason = "edge not found all round (cut by the image border or weak)";
    return false;
  }
  const auto fit = FitEllipse(*points, opt_.ellipse_fit);
  if (!fit) {
    *reason = "edge points do not fit an ellipse";
    return false;
  }
  *fitted = fit->ellipse;
  *rms = fit->rms_residual;
  return true;
}

bool Detector::Refine(const Blob& blob, Candidate* cand, std::string* reason) {
  const bool rings = target_.type == TargetType::kConcentricRings;
  double hw = std::clamp(0.3 * blob.outer.b, 1.5, opt_.edges.search_half_width_px);
  if (rings) hw = std::min(hw, std::max(1.0, 0.45 * (blob.outer.b - blob.hole.b)));
  Ellipse outer = blob.outer, inner = blob.hole;
  double rms_o = 0, rms_i = 0;
  // Two passes: coarse contour ellipse, then the first subpixel fit as seed.
  for (int pass = 0; pass < 2; ++pass) {
    const double w = pass == 0 ? hw : std::min(hw, 1.5);
    if (!MeasureEdges(outer, true, w, &cand->outer_edge, &outer, &rms_o, reason)) return false;
    if (rings && !MeasureEdges(inner, false, w, &cand->inner_edge, &inner, &rms_i, reason)) {
      *reason = "inner ring: " + *reason;
      return false;
    }
  }
  cand->outer = outer;
  cand->inner = inner;
  cand->fit_rms = std::max(rms_o, rms_i);
  cand->size = std::sqrt(outer.a * outer.b);
  if (cand->fit_rms > opt_.max_fit_rms_px) {
    *reason = util::StrCat("ellipse fit residual ", cand->fit_rms, " px");
    return false;
  }
  if (outer.AxisRatio() < opt_.min_axis_ratio) {
    *reason = "too elongated (axis ratio)";
    return false;
  }
  if (rings) {
    if ((inner.centre - outer.centre).norm() > opt_.max_concentricity * outer.b) {
      *reason = "ring ellipses not concentric";
      return false;
    }
    const auto c = RingCentre(outer, inner, target_.inner_radius_mm / target_.outer_radius_mm);
    if (!c || (*c - outer.centre).norm() > 0.5 * outer.b) {
      *reason = "unstable ring centre (pole-polar disagrees with the ellipse centres)";
      return false;
    }
    cand->centre = *c;
    // Centre dot: the centre is dark like the annulus, unlike the bright hole around it.
    // Medians over rays from the centre toward the outer ellipse, at the radii (as fractions of
    // the outer radius) of the annulus and of the hole between dot and inner edge.
    const double ro = target_.outer_radius_mm, ri = target_.inner_radius_mm;
    const double s_ring = 0.5 * (1 + ri / ro);
    const double s_hole = 0.5 * (ri + target_.dot_radius_mm) / ro;
    std::vector<double> ring_v, hole_v;
    for (int k = 0; k < 12; ++k) {
      const Vec2 ray = outer.PointAt(2 * M_PI * k / 12) - *c;
      ring_v.push_back(gradient_.Intensity(*c + s_ring * ray));
      hole_v.push_back(gradient_.Intensity(*c + s_hole * ray));
    }
    std::nth_element(ring_v.begin(), ring_v.begin() + 6, ring_v.end());
    std::nth_element(hole_v.begin(), hole_v.begin() + 6, hole_v.end());
    const double i_ring = ring_v[6], i_hole = hole_v[6];
    const double i_centre = gradient_.Intensity(*c);
    cand->has_dot =
        target_.dot_radius_mm > 0 && i_hole - i_ring > 10 && i_centre < 0.5 * (i_hole + i_ring);
  } else {
    cand->centre = outer.centre;
  }
  return true;
}

// Image position at grid offset (0, 0) from a DLT homography fitted to (grid offset, image
// point) pairs; nullopt when they do not span both grid directions.
std::optional<Vec2> PredictHomography(const std::vector<std::pair<Vec2, Vec2>>& nb) {
  bool di_spread = false, dj_spread = false;
  for (const auto& [g, p] : nb) {
    di_spread |= g.x() != nb[0].first.x();
    dj_spread |= g.y() != nb[0].first.y();
  }
  if (!di_spread || !dj_spread) return std::nullopt;
  Vec2 mean = Vec2::Zero();
  for (const auto& [g, p] : nb) mean += p;
  mean /= nb.size();
  double scale = 0;
  for (const auto& [g, p] : nb) scale += (p - mean).norm();
  scale = nb.size() / std::max(scale, 1e-9);
  Eigen::MatrixXd a(2 * nb.size(), 9);
  for (size_t k = 0; k < nb.size(); ++k) {
    const double x = nb[k].first.x(), y = nb[k].first.y();
    const Vec2 q = (nb[k].second - mean) * scale;
    a.row(2 * k) << x, y, 1, 0, 0, 0, -q.x() * x, -q.x() * y, -q.x();
    a.row(2 * k + 1) << 0, 0, 0, x, y, 1, -q.y() * x, -q.y() * y, -q.y();
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeFullV);
  const Eigen::VectorXd h = svd.matrixV().col(8);
  if (std::abs(h(8)) < 1e-12) return std::nullopt;
  const Vec2 q(h(2) / h(8), h(5) / h(8));
  const Vec2 p = q / scale + mean;
  if (!p.allFinite()) return std::nullopt;
  return p;
}

void Detector::Grow(GridMap* grid, bool bounded, int max_extent) const {
  std::vector<bool> used(cands_.size(), false);
  for (const auto& [key, idx] : *grid) used[idx] = true;
  const double tol = opt_.grid_tolerance;
  for (int round = 0; round < 4 * (target_.rows + target_.cols) + 8; ++round) {
    bool changed = false;
    std::vector<std::pair<int, int>> frontier;
    int imin = 1 << 20, imax = -(1 << 20), jmin = 1 << 20, jmax = -(1 << 20);
    for (const auto& [key, idx] : *grid) {
      imin = std::min(imin, key.first);
      imax = std::max(imax, key.first);
      jmin = std::min(jmin, key.second);
      jmax = std::max(jmax, key.second);
    }
    for (const auto& [key, idx] : *grid) {
      const int di[4] = {1, -1, 0, 0}, dj[4] = {0, 0, 1, -1};
      for (int k = 0; k < 4; ++k) {
        const std::pair<int, int> q(key.first + di[k], key.second + dj[k]);
        if (grid->count(q)) continue;
        if (bounded &&
            (q.first < 0 || q.first >= target_.rows || q.second < 0 || q.second >= target_.cols)) {
          continue;
        }
        if (!bounded) {
          const int ei = std::max(imax, q.first) - std::min(imin, q.first) + 1;
          const int ej = std::max(jmax, q.second) - std::min(jmin, q.second) + 1;
          if (ei > max_extent || ej > max_extent) continue;
        }
        frontier.push_back(q);
      }
    }
    std::sort(frontier.begin(), frontier.end());
    frontier.erase(std::unique(frontier.begin(), frontier.end()), frontier.end());
    for (const auto& q : frontier) {
      if (grid->count(q)) continue;
      // Local affine grid -> image from assigned features within two steps.
      std::vector<std::pair<Vec2, Vec2>> nb;
      for (int di = -2; di <= 2; ++di) {
        for (int dj = -2; dj <= 2; ++dj) {
          auto it = grid->find({q.first + di, q.second + dj});
          if (it != grid->end()) nb.push_back({Vec2(di, dj), cands_[it->second].centre});
        }
      }
      if (nb.size() < 3) continue;
      Eigen::MatrixXd a(nb.size(), 3);
      Eigen::MatrixXd b(nb.size(), 2);
      for (size_t k = 0; k < nb.size(); ++k) {
        const double w = 1.0 / nb[k].first.squaredNorm();
        a.row(k) << w * nb[k].first.x(), w * nb[k].first.y(), w;
        b.row(k) = w * nb[k].second.transpose();
      }
      Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeThinU | Eigen::ComputeThinV);
      if (svd.singularValues()(2) < 1e-6 * svd.singularValues()(0)) continue;  // collinear
      const Eigen::MatrixXd x = svd.solve(b);  // rows: d/di, d/dj, offset
      Vec2 pred = x.row(2).transpose();
      // With enough neighbours spread in both directions a local homography extrapolates
      // perspective foreshortening (large features, strong tilt) that the affine model misses.
      if (nb.size() >= 6) {
        const auto h = PredictHomography(nb);
        if (h) pred = *h;
      }
      const double spacing = std::min(x.row(0).norm(), x.row(1).norm());  // local image spacing, px
      int best = -1;
      double d1 = 1e300, d2 = 1e300;
      for (size_t c = 0; c < cands_.size(); ++c) {
        const double d = (cands_[c].centre - pred).norm();
        if (d < d1) {
          d2 = d1;
          d1 = d;
          best = static_cast<int>(c);
        } else if (d < d2) {
          d2 = d;
        }
      }
      if (best < 0 || used[best] || d1 > tol * spacing || d2 < d1 + tol * spacing) continue;
      // Size consistent with the nearest assigned neighbour.
      double nsize = 0, nd = 1e300;
      for (const auto& [gq, gp] : nb) {
        if (gq.squaredNorm() < nd) {
          nd = gq.squaredNorm();
          nsize = 0;
          for (const auto& [key, idx] : *grid) {
            if (key.first == q.first + static_cast<int>(gq.x()) &&
                key.second == q.second + static_cast<int>(gq.y())) {
              nsize = cands_[idx].size;
            }
          }
        }
        (void)gp;
      }
      if (nsize > 0 && std::abs(cands_[best].size / nsize - 1) > opt_.size_tolerance) continue;
      (*grid)[q] = best;
      used[best] = true;
      changed = true;
    }
    if (!changed) break;
  }
}

// Maps a grown lattice (any unimodular basis) onto the asymmetric board: lattice coordinates
// (p, q) with board position p (s, 0) + q (s/2, s), i.e. row = q, col = p + floor(q / 2).
// Tries the small unimodular basis changes; returns how many distinct right-handed orderings
// cover the whole board exactly (1 = unambiguous, stored in *result).
int Detector::OrderAsymmetric(const GridMap& grown, GridMap* result) const {
  std::set<std::vector<int>> seen;
  int found = 0;
  for (int m00 = -2; m00 <= 2; ++m00) {
    for (int m01 = -2; m01 <= 2; ++m01) {
      for (int m10 = -2; m10 <= 2; ++m10) {
        for (int m11 = -2; m11 <= 2; ++m11) {
          if (std::abs(m00 * m11 - m01 * m10) != 1) continue;
          std::vector<std::array<int, 3>> pqi;
          int qmin = 1 << 20;
          for (const auto& [key, idx] : grown) {
            const int p = m00 * key.first + m01 * key.second;
            const int q = m10 * key.first + m11 * key.second;
            pqi.push_back({p, q, idx});
            qmin = std::min(qmin, q);
          }
          GridMap g;
          int cmin = 1 << 20;
          std::vector<std::array<int, 3>> rc;
          for (const auto& [p, q, idx] : pqi) {
            const int row = q - qmin;
            const int half_q = q >= 0 ? q / 2 : -((1 - q) / 2);  // floor(q / 2)
            const int col = p + half_q;
            rc.push_back({row, col, idx});
            cmin = std::min(cmin, col);
          }
          bool ok = (qmin % 2 == 0);  // row 0 must be an unshifted row
          for (const auto& [row, col, idx] : rc) {
            const int c = col - cmin;
            if (row >= target_.rows || c >= target_.cols ||
                !g.emplace(std::make_pair(row, c), idx).second)
              ok = false;
          }
          if (!ok || static_cast<int>(g.size()) != target_.NumFeatures()) continue;
          // Right-handed in the image (board seen from its front).
          const auto a = g.find({0, 0}), b = g.find({0, 1}), c = g.find({2, 0});
          if (a == g.end() || b == g.end() || c == g.end()) continue;
          const Vec2 dcol = cands_[b->second].centre - cands_[a->second].centre;
          const Vec2 drow = cands_[c->second].centre - cands_[a->second].centre;
          if (dcol.x() * drow.y() - dcol.y() * drow.x() <= 0) continue;
          std::vector<int> key;
          for (const auto& [rcol, idx] : g) key.push_back(idx);
          if (seen.insert(key).second) {
            ++found;
            *result = g;
          }
        }
      }
    }
  }
  return found;
}

bool Detector::Order(GridMap* result) {
  if (target_.type == TargetType::kConcentricRings && !target_.distinct_features.empty()) {
    return OrderByDistinctFeatures(result);
  }
  return OrderCircleGrid(result);
}

// Ring boards with centre-dot features: the dots seed the lattice at their known positions,
// which fixes the orientation without needing the whole board in view.
bool Detector::OrderByDistinctFeatures(GridMap* result) {
  const int n = static_cast<int>(cands_.size());
  std::vector<int> dots;
  for (int i = 0; i < n; ++i) {
    if (cands_[i].has_dot) dots.push_back(i);
  }
  const auto& df = target_.distinct_features;
  if (dots.size() < df.size()) {
    out_->status = DetectionStatus::kNotFound;
    out_->message = util::StrCat("found ", dots.size(), " of ", df.size(),
                                 " distinct (centre-dot) features: orientation unknown");
    return false;
  }
  if (dots.size() > static_cast<size_t>(kMaxDistinctFeatures)) {
    // Every assignment of dots to the declared positions is tried: more than a few dots cannot
    // be the declared features. A board whose every ring is dotted is a symmetric grid.
    out_->status = DetectionStatus::kAmbiguous;
    out_->message = util::StrCat(dots.size(), " rings carry a centre dot but the target declares ",
                                 df.size(), " distinct features (at most ", kMaxDistinctFeatures,
                                 " dotted rings can be told apart)");
    if (2 * dots.size() >= cands_.size()) {
      out_->warning =
          "most rings carry a centre dot: if every ring of the board has one, declare "
          "\"distinct_features\": [] and the board is ordered like a symmetric grid";
    }
    return false;
  }
  // Try every assignment of dot features to the distinct positions.
  std::vector<int> perm(dots.size());
  for (size_t i = 0; i < perm.size(); ++i) perm[i] = static_cast<int>(i);
  int best_count = 0, best_mismatches = 2;
  std::vector<GridMap> best;
  std::sort(perm.begin(), perm.end());
  std::set<std::vector<int>> seen;
  do {
    std::vector<int> pick(perm.begin(), perm.begin() + df.size());
    if (!seen.insert(pick).second) continue;
    GridMap grid;
    for (size_t k = 0; k < df.size(); ++k) grid[df[k]] = dots[pick[k]];
    // Handedness and plausibility of the seed: a right-handed, not too sheared lattice.
    if (df.size() >= 3) {
      Eigen::Matrix3d a;
      Eigen::Matrix<double, 3, 2> b;
      for (int k = 0; k < 3; ++k) {
        a.row(k) << df[k].first, df[k].second, 1;
        b.row(k) = cands_[dots[pick[k]]].centre.transpose();
      }
      if (std::abs(a.determinant()) < 1e-9) continue;
      const Eigen::Matrix<double, 3, 2> x = a.inverse() * b;
      const Vec2 drow = x.row(0).transpose(), dcol = x.row(1).transpose();
      const double cross = dcol.x() * drow.y() - dcol.y() * drow.x();
      if (cross <= 0) continue;
      // Foreshortening up to the steepest accepted view (min_axis_ratio).
      const double ratio = drow.norm() / dcol.norm();
      const double limit = 1.2 / opt_.min_axis_ratio;
      if (ratio < 1 / limit || ratio > limit) continue;
      const double size = cands_[dots[pick[0]]].size;
      const double expect = size * target_.spacing_mm / target_.outer_radius_mm;
      if (std::max(drow.norm(), dcol.norm()) < 0.3 * expect ||
          std::min(drow.norm(), dcol.norm()) > 3 * expect) {
        continue;
      }
    }
    Grow(&grid, true, 0);
    // The centre dots must sit at the distinct positions: a wrongly seeded grid puts the
    // real dots elsewhere. One disagreement (a dot misread at a steep view) is tolerated;
    // the ordering with the fewest disagreements, then the most features, wins.
    int mismatches = 0;
    for (const auto& [key, idx] : grid) {
      if (cands_[idx].has_dot != target_.IsDistinct(key.first, key.second)) ++mismatches;
    }
    if (mismatches > 1) continue;
    const int count = static_cast<int>(grid.size());
    if (mismatches < best_mismatches || (mismatches == best_mismatches && count > best_count)) {
      best_mismatches = mismatches;
      best_count = count;
      best = {grid};
    } else if (mismatches == best_mismatches && count == best_count && count > 0) {
      best.push_back(grid);
    }
  } while (std::next_permutation(perm.begin(), perm.end()));
  if (best.empty() || best_count < static_cast<int>(df.size()) + 1) {
    out_->status = DetectionStatus::kNotFound;
    out_->message = "the distinct features do not seed a consistent grid";
    return false;
  }
  if (best.size() > 1) {
    out_->status = DetectionStatus::kAmbiguous;
    out_->message = "several grid orderings fit equally well; refusing the board";
    return false;
  }
  *result = best[0];
  return true;
}

// Circle grids: seed from neighbour triples, grow, keep the complete grid.
bool Detector::OrderCircleGrid(GridMap* result) {
  const int n = static_cast<int>(cands_.size());
  const bool asymmetric = target_.type == TargetType::kAsymmetricCircleGrid;
  bool ambiguous = false;
  const int need = target_.rows * target_.cols;
  const int max_extent =
      asymmetric ? target_.rows + target_.cols : std::max(target_.rows, target_.cols);
  GridMap best;
  int best_partial = 0;
  std::vector<int> order(n);
  for (int i = 0; i < n; ++i) order[i] = i;
  for (int c0 : order) {
    std::vector<std::pair<double, int>> nbs;
    for (int j = 0; j < n; ++j) {
      if (j != c0) nbs.push_back({(cands_[j].centre - cands_[c0].centre).norm(), j});
    }
    std::sort(nbs.begin(), nbs.end());
    if (nbs.size() < 2) break;
    // Basis: the nearest neighbour, then each of the next few non-collinear ones (a skewed,
    // diagonal basis cannot grow to the full grid within its extent, so the right one wins).
    const int n1 = nbs[0].second;
    const Vec2 u = cands_[n1].centre - cands_[c0].centre;
    int tried = 0;
    for (size_t k = 1; k < std::min<size_t>(nbs.size(), 8) && tried < 3; ++k) {
      const int n2 = nbs[k].second;
      const Vec2 v = cands_[n2].centre - cands_[c0].centre;
      const double cosang = u.dot(v) / (u.norm() * v.norm());
      if (std::abs(cosang) > 0.85 || v.norm() > 3 * u.norm()) continue;
      ++tried;
      GridMap grid;
      grid[{0, 0}] = c0;
      grid[{0, 1}] = n1;
      grid[{(u.x() * v.y() - u.y() * v.x()) > 0 ? 1 : -1, 0}] = n2;
      Grow(&grid, false, max_extent);
      // Valid only as a complete rows x cols rectangle (either way round).
      int i0 = 1 << 20, j0 = 1 << 20, i1 = -(1 << 20), j1 = -(1 << 20);
      for (const auto& [key, idx] : grid) {
        i0 = std::min(i0, key.first);
        j0 = std::min(j0, key.second);
        i1 = std::max(i1, key.first);
        j1 = std::max(j1, key.second);
      }
      const int ei = i1 - i0 + 1, ej = j1 - j0 + 1;
      if (asymmetric) {
        if (static_cast<int>(grid.size()) == need) {
          GridMap ordered;
          const int found = OrderAsymmetric(grid, &ordered);
          if (found == 1) {
            *result = ordered;
            return true;
          }
          if (found > 1) ambiguous = true;
        }
        best_partial = std::max(best_partial, static_cast<int>(grid.size()));
        continue;
      }
      const bool rectangle =
          static_cast<int>(grid.size()) == need && ((ei == target_.rows && ej == target_.cols) ||
                                                    (ei == target_.cols && ej == target_.rows));
      if (rectangle) {
        best = grid;
        break;
      }
      best_partial = std::max(best_partial, static_cast<int>(grid.size()));
    }
    if (static_cast<int>(best.size()) == need) break;
  }
  if (asymmetric || static_cast<int>(best.size()) < need) {
    if (ambiguous) {
      out_->status = DetectionStatus::kAmbiguous;
      out_->message = "asymmetric grid: several orderings fit; refusing the board";
      return false;
    }
    out_->status = DetectionStatus::kNotFound;
    out_->message = util::StrCat("found ", best_partial, " of ", need,
                                 " grid features; a symmetric grid must be fully visible");
    return false;
  }
  return OrientSymmetricGrid(best, result);
}

// A complete symmetric grid has four candidate orientations; the board convention (columns
// run to +x in the image) picks one, and a tie means the board cannot be oriented.
bool Detector::OrientSymmetricGrid(const GridMap& best, GridMap* result) {
  int imin = 1 << 20, jmin = 1 << 20, imax = -(1 << 20), jmax = -(1 << 20);
  for (const auto& [key, idx] : best) {
    imin = std::min(imin, key.first);
    jmin = std::min(jmin, key.second);
    imax = std::max(imax, key.first);
    jmax = std::max(jmax, key.second);
  }
  // Among the proper rotations of the grid that fit rows x cols, take the one whose column
  // direction points most to +x in the image.
  double best_score = -1e300;
  int ties = 0;
  GridMap chosen;
  for (int rot = 0; rot < 4; ++rot) {
    GridMap g;
    for (const auto& [key, idx] : best) {
      int i = key.first - imin, j = key.second - jmin;
      const int h = imax - imin, w = jmax - jmin;
      int ri = i, rj = j;
      if (rot == 1) {
        ri = j;
        rj = h - i;
      } else if (rot == 2) {
        ri = h - i;
        rj = w - j;
      } else if (rot == 3) {
        ri = w - j;
        rj = i;
      }
      g[{ri, rj}] = idx;
    }
    bool fits = true;
    for (const auto& [key, idx] : g) {
      if (key.first >= target_.rows || key.second >= target_.cols) fits = false;
    }
    if (!fits) continue;
    Vec2 dir = Vec2::Zero();
    for (const auto& [key, idx] : g) {
      auto it = g.find({key.first, key.second + 1});
      if (it != g.end()) dir += (cands_[it->second].centre - cands_[idx].centre).normalized();
    }
    const double score = dir.normalized().x();
    if (score > best_score + 1e-9) {
      best_score = score;
      chosen = g;
      ties = 0;
    } else if (std::abs(score - best_score) <= 1e-9) {
      ++ties;
    }
  }
  if (chosen.empty() || ties > 0) {
    out_->status = DetectionStatus::kAmbiguous;
    out_->message = "grid orientation ambiguous";
    return false;
  }
  *result = chosen;
  return true;
}

void Detector::FindCandidates() {
  std::vector<Blob> blobs;
  FindBlobs(&blobs);
  // Subpixel measurement of every blob in parallel (read-only image data); merged in blob
  // order so the result does not depend on the thread count.
  std::vector<Candidate> refined(blobs.size());
  std::vector<std::string> reasons(blobs.size());
  std::vector<char> ok(blobs.size(), 0);
  tbb::parallel_for(size_t{0}, blobs.size(),
                    [&](size_t i) { ok[i] = Refine(blobs[i], &refined[i], &reasons[i]) ? 1 : 0; });
  for (size_t i = 0; i < blobs.size(); ++i) {
    if (ok[i]) {
      cands_.push_back(std::move(refined[i]));
    } else {
      Reject(blobs[i].outer.centre, reasons[i]);
    }
  }
  // Drop near-duplicates (a blob and its hole seen as two blobs, etc.): keep the larger.
  std::sort(cands_.begin(), cands_.end(),
            [](const Candidate& a, const Candidate& b) { return a.size > b.size; });
  std::vector<Candidate> unique;
  for (auto& c : cands_) {
    bool dup = false;
    for (const auto& u : unique) {
      if ((u.centre - c.centre).norm() < 0.5 * u.outer.b) dup = true;
    }
    if (dup) {
      Reject(c.centre, "inside another feature");
    } else {
      unique.push_back(std::move(c));
    }
  }
  cands_ = std::move(unique);
  out_->num_candidates = static_cast<int>(cands_.size());
}

std::vector<FeatureObservation> Detector::CandidateObservations() const {
  std::vector<FeatureObservation> out;
  for (const Candidate& c : cands_) {
    FeatureObservation f;
    f.row = f.col = -1;
    f.centre_px = c.centre;
    f.outer_edge_px = c.outer_edge;
    f.inner_edge_px = c.inner_edge;
    f.outer = c.outer;
    f.inner = c.inner;
    f.fit_rms_px = c.fit_rms;
    out.push_back(std::move(f));
  }
  return out;
}

// A ring board declared as solid circles: its rings are rejected as "has a hole" and hardly
// anything else is a candidate.
void Detector::WarnAboutDeclaration() {
  if (target_.type == TargetType::kConcentricRings || target_.type == TargetType::kChessboard) {
    return;
  }
  int holes = 0;
  for (const auto& r : out_->rejected) holes += r.reason == kHasHole ? 1 : 0;
  if (holes >= 3 && holes > static_cast<int>(cands_.size())) {
    out_->warning = util::StrCat(holes,
                                 " dark blobs have a concentric hole: is this a ring board "
                                 "declared as plain circles? (\"type\": \"rings\")");
  }
}

void Detector::Run() {
  FindCandidates();
  WarnAboutDeclaration();
  GridMap grid;
  if (!Order(&grid)) return;
  std::vector<bool> used(cands_.size(), false);
  for (const auto& [key, idx] : grid) {
    const Candidate& c = cands_[idx];
    FeatureObservation f;
    f.row = key.first;
    f.col = key.second;
    f.centre_px = c.centre;
    f.outer_edge_px = c.outer_edge;
    f.inner_edge_px = c.inner_edge;
    f.outer = c.outer;
    f.inner = c.inner;
    f.fit_rms_px = c.fit_rms;
    out_->features.push_back(std::move(f));
    used[idx] = true;
  }
  for (size_t i = 0; i < cands_.size(); ++i) {
    if (!used[i]) Reject(cands_[i].centre, "not on the grid");
  }
  out_->status = DetectionStatus::kOk;
}

// The 8-bit copy for blob search and OpenCV's chessboard finder, and the full-precision image on
// the same 0-255 scale (min-max scaled like cv::normalize) for subpixel work.
struct ScaledImages {
  cv::Mat gray8, fine;
};
ScaledImages ScaleForDetection(const cv::Mat& gray) {
  ScaledImages out;
  if (gray.depth() != CV_16U) {
    out.gray8 = out.fine = gray;
    return out;
  }
  double lo = 0, hi = 0;
  cv::minMaxLoc(gray, &lo, &hi);
  const double scale = hi > lo ? 255.0 / (hi - lo) : 1.0;
  gray.convertTo(out.fine, CV_32F, scale, -lo * scale);
  out.fine.convertTo(out.gray8, CV_8U);  // rounds and saturates
  return out;
}

void DetectChessboard(const ScaledImages& images, const CalibrationTarget& target,
                      TargetDetection* out) {
  const cv::Mat& gray8 = images.gray8;
  const cv::Size pattern(target.cols, target.rows);
  std::vector<cv::Point2f> corners;
  bool found = cv::findChessboardCorners(
      gray8, pattern, corners, cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
  if (found) {
    cv::cornerSubPix(images.fine, corners, cv::Size(11, 11), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 30, 0.01));
  } else {
    found = cv::findChessboardCornersSB(
        gray8, pattern, corners,
        cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY);
  }
  if (!found || static_cast<int>(corners.size()) != target.NumFeatures()) {
    out->status = DetectionStatus::kNotFound;
    out->message = "OpenCV found no complete chessboard";
    return;
  }
  for (int k = 0; k < static_cast<int>(corners.size()); ++k) {
    FeatureObservation f;
    f.row = k / target.cols;
    f.col = k % target.cols;
    f.centre_px = {corners[k].x, corners[k].y};
    out->features.push_back(f);
  }
  out->num_candidates = static_cast<int>(corners.size());
  out->status = DetectionStatus::kOk;
}

}  // namespace

TargetDetection DetectTarget(const cv::Mat& gray, const CalibrationTarget& target,
                             const DetectionOptions& options) {
  options.Check();
  target.Check();
  if (gray.empty() || gray.channels() != 1 || (gray.depth() != CV_8U && gray.depth() != CV_16U)) {
    throw Error("DetectTarget: expected a non-empty single-channel 8- or 16-bit image");
  }
  if (target.type == TargetType::kConcentricRings &&
      target.distinct_features.size() > static_cast<size_t>(kMaxDistinctFeatures)) {
    throw Error(util::StrCat(
        "the target declares ", target.distinct_features.size(),
        " distinct (centre-dot) features; the detector tells at most ", kMaxDistinctFeatures,
        " apart. A board whose every ring has a centre dot declares \"distinct_features\": [] "
        "and is ordered like a symmetric grid"));
  }
  util::Timer timer;
  const ScaledImages images = ScaleForDetection(gray);
  TargetDetection out;
  out.image_width = gray.cols;
  out.image_height = gray.rows;
  if (target.type == TargetType::kChessboard) {
    DetectChessboard(images, target, &out);
  } else {
    Detector d(images.gray8, images.fine, target, options, &out);
    d.Run();
  }
  if (!out.warning.empty()) {
    out.message += util::StrCat(out.message.empty() ? "" : "; ", "warning: ", out.warning);
  }
  out.seconds = timer.ElapsedSeconds();
  return out;
}

std::string RingDetection::BriefReport() const {
  return util::StrCat(rings.size(), " rings, ", rejected.size(), " blobs rejected");
}

RingDetection DetectRings(const cv::Mat& gray, double inner_to_outer_ratio,
                          const DetectionOptions& options) {
  options.Check();
  util::CheckOption(inner_to_outer_ratio > 0 && inner_to_outer_ratio < 1, "DetectRings",
                    "inner_to_outer_ratio", inner_to_outer_ratio, "must be in (0, 1)");
  if (gray.empty() || gray.channels() != 1 || (gray.depth() != CV_8U && gray.depth() != CV_16U)) {
    throw Error("DetectRings: expected a non-empty single-channel 8- or 16-bit image");
  }
  const ScaledImages images = ScaleForDetection(gray);
  // A ring target of unit outer radius without centre dots: the candidate stage of the board
  // detector is exactly a ring finder.
  CalibrationTarget rings;
  rings.type = TargetType::kConcentricRings;
  rings.outer_radius_mm = 1.0;
  rings.inner_radius_mm = inner_to_outer_ratio;
  rings.dot_radius_mm = 0;
  rings.distinct_features.clear();
  TargetDetection scratch;
  Detector d(images.gray8, images.fine, rings, options, &scratch);
  d.FindCandidates();
  RingDetection out;
  out.rings = d.CandidateObservations();
  out.rejected = std::move(scratch.rejected);
  return out;
}

}  // namespace fringe::calib
