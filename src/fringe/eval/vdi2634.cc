#include "fringe/eval/vdi2634.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "fringe/util/error.h"
#include "fringe/util/random.h"

namespace fringe::eval {
namespace {

using Points = std::vector<Eigen::Vector3d>;

// Algebraic sphere |p|^2 + d.p + g = 0 through the points (least squares), centred on their mean
// for conditioning.
bool AlgebraicSphere(const Points& pts, Eigen::Vector3d* centre, double* radius) {
  if (pts.size() < 4) return false;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : pts) mean += p;
  mean /= static_cast<double>(pts.size());
  Eigen::MatrixXd a(pts.size(), 4);
  Eigen::VectorXd b(pts.size());
  for (size_t i = 0; i < pts.size(); ++i) {
    const Eigen::Vector3d q = pts[i] - mean;
    a.row(i) << q.x(), q.y(), q.z(), 1.0;
    b(i) = -q.squaredNorm();
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(a);
  if (qr.rank() < 4) return false;
  const Eigen::Vector4d x = qr.solve(b);
  const Eigen::Vector3d c = -0.5 * x.head<3>();
  const double r2 = c.squaredNorm() - x(3);
  if (!(r2 > 0) || !std::isfinite(r2)) return false;
  *centre = c + mean;
  *radius = std::sqrt(r2);
  return true;
}

std::vector<double> RadialResiduals(const Points& pts, const Eigen::Vector3d& c, double r) {
  std::vector<double> res(pts.size());
  for (size_t i = 0; i < pts.size(); ++i) res[i] = (pts[i] - c).norm() - r;
  return res;
}

double Rms(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x * x;
  return v.empty() ? 0 : std::sqrt(s / v.size());
}

double Range(const std::vector<double>& v) {
  if (v.empty()) return 0;
  const auto [mn, mx] = std::minmax_element(v.begin(), v.end());
  return *mx - *mn;
}

Points Select(const Points& pts, const std::vector<size_t>& idx) {
  Points out;
  out.reserve(idx.size());
  for (size_t i : idx) out.push_back(pts[i]);
  return out;
}

Points FinitePoints(const PointCloud& cloud, std::vector<Eigen::Vector3d>* normals) {
  Points pts;
  pts.reserve(cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    const auto& p = cloud.points[i];
    if (!p.allFinite()) continue;
    if (normals) {
      if (!cloud.has_normals() || !cloud.normals[i].allFinite()) continue;
      normals->push_back(cloud.normals[i]);
    }
    pts.push_back(p);
  }
  return pts;
}

// Seeded subsample of at most n indices.
std::vector<size_t> Subsample(size_t size, int n, util::Rng& rng) {
  std::vector<size_t> idx(size);
  std::iota(idx.begin(), idx.end(), 0);
  if (static_cast<int>(size) > n) {
    std::shuffle(idx.begin(), idx.end(), rng);
    idx.resize(n);
  }
  return idx;
}

// RANSAC for a sphere of nominal radius r0. With normals, one point p and its (outward) normal
// give the centre p - r0 n; without, four points near a random point are fitted.
bool FindSphere(const Points& pts, const Points& normals, double r0, const VdiOptions& o,
                uint64_t stream, Eigen::Vector3d* best_centre) {
  util::Rng rng(util::MixSeed(o.seed, stream));
  const std::vector<size_t> sample = Subsample(pts.size(), o.ransac_sample_points, rng);
  if (sample.size() < 4) return false;
  std::uniform_int_distribution<size_t> pick(0, sample.size() - 1);
  // Wide band for scoring: the normal-based centre is off by r0 * (normal error).
  const double band = std::max(o.inlier_band_mm, 0.05 * r0);
  int best_score = 0;
  std::vector<size_t> near;
  for (int it = 0; it < o.ransac_iterations; ++it) {
    const size_t i0 = sample[pick(rng)];
    Eigen::Vector3d c;
    if (!normals.empty()) {
      c = pts[i0] - r0 * normals[i0];
    } else {
      near.clear();
      for (size_t j : sample) {
        if ((pts[j] - pts[i0]).squaredNorm() < 4 * r0 * r0) near.push_back(j);
      }
      if (near.size() < 4) continue;
      std::uniform_int_distribution<size_t> pn(0, near.size() - 1);
      Points four = {pts[i0], pts[near[pn(rng)]], pts[near[pn(rng)]], pts[near[pn(rng)]]};
      double r;
      if (!AlgebraicSphere(four, &c, &r) || std::abs(r - r0) > o.radius_tolerance * r0) continue;
    }
    int score = 0;
    for (size_t j : sample) score += std::abs((pts[j] - c).norm() - r0) < band;
    if (score > best_score) {
      best_score = score;
      *best_centre = c;
    }
  }
  return best_score >= 4;
}

// Mean unit direction from `centre` of the points within `band` of the sphere (centre, r), how
// many there are, and how many lie inside the sphere (nearer the centre than r - band). The
// mean direction's norm is (1 + cos a) / 2 for points spread evenly over a cap of half angle a:
// near 1 for the small cap where a large sphere touches a plane.
struct SphereSupport {
  int inliers = 0;
  int inside = 0;
  double mean_direction_norm = 1;
};
SphereSupport Support(const Points& pts, const std::vector<size_t>& idx,
                      const Eigen::Vector3d& centre, double r, double band) {
  SphereSupport s;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (size_t j : idx) {
    const Eigen::Vector3d d = pts[j] - centre;
    const double n = d.norm();
    if (n < r - band) {
      ++s.inside;
    } else if (n < r + band && n > 0) {
      sum += d / n;
      ++s.inliers;
    }
  }
  if (s.inliers > 0) s.mean_direction_norm = sum.norm() / s.inliers;
  return s;
}

// RANSAC for a sphere of unknown radius: each hypothesis is the sphere through four points
// within a neighbourhood of random size (log-uniform between 1/50 and 1/2 of the sample's
// extent) around a random point; it scores the sample points within inlier_band_mm. It counts
// only when its radius is at most max_radius, its inliers cover a cap of at least
// min_cap_half_angle_deg (a large sphere touching a plane has a small cap) and at most
// kMaxInsideFraction of them lie inside it (a scanned sphere is solid: a large sphere cutting a
// plane in a circle has the plane's disk inside it).
constexpr double kMaxInsideFraction = 0.1;
bool FindSphereFreeRadius(const Points& pts, const VdiOptions& o, uint64_t stream,
                          Eigen::Vector3d* best_centre, double* best_radius) {
  util::Rng rng(util::MixSeed(o.seed, stream));
  const std::vector<size_t> sample = Subsample(pts.size(), o.ransac_sample_points, rng);
  if (sample.size() < 4) return false;
  Eigen::AlignedBox3d box;
  for (size_t j : sample) box.extend(pts[j]);
  const double extent = box.diagonal().norm();
  if (!(extent > 0)) return false;
  const double max_radius = o.max_diameter_mm > 0 ? 0.5 * o.max_diameter_mm : extent;
  const double max_mean_norm = 0.5 * (1 + std::cos(o.min_cap_half_angle_deg * M_PI / 180));
  std::uniform_int_distribution<size_t> pick(0, sample.size() - 1);
  std::uniform_real_distribution<double> log_scale(std::log(extent / 50), std::log(extent / 2));
  int best_score = 0;
  std::vector<size_t> near;
  // Four times the iterations of the known-radius search: a hypothesis needs four points on
  // the artefact instead of one.
  for (int it = 0; it < 4 * o.ransac_iterations; ++it) {
    const size_t i0 = sample[pick(rng)];
    const double reach = std::exp(log_scale(rng));
    near.clear();
    for (size_t j : sample) {
      if (j != i0 && (pts[j] - pts[i0]).squaredNorm() < reach * reach) near.push_back(j);
    }
    if (near.size() < 3) continue;
    std::uniform_int_distribution<size_t> pn(0, near.size() - 1);
    const Points four = {pts[i0], pts[near[pn(rng)]], pts[near[pn(rng)]], pts[near[pn(rng)]]};
    Eigen::Vector3d c;
    double r;
    if (!AlgebraicSphere(four, &c, &r) || r > max_radius) continue;
    // The same band for every radius: a band growing with the radius would favour large
    // spheres, which then gather noisy background points.
    const SphereSupport support = Support(pts, sample, c, r, o.inlier_band_mm);
    if (support.inliers > best_score && support.mean_direction_norm <= max_mean_norm &&
        support.inside <= kMaxInsideFraction * support.inliers) {
      best_score = support.inliers;
      *best_centre = c;
      *best_radius = r;
    }
  }
  return best_score >= 4;
}

// Least-squares sphere on the points near the surface, re-selecting the band around each fit.
bool RefineSphere(const Points& pts, double r0, const VdiOptions& o, Eigen::Vector3d* centre,
                  Points* members) {
  double r = r0;
  double band = std::max(o.inlier_band_mm, 0.05 * r0);
  for (int pass = 0; pass < 4; ++pass) {
    members->clear();
    for (const auto& p : pts) {
      if (std::abs((p - *centre).norm() - r) < band) members->push_back(p);
    }
    const SphereFit fit = FitSphere(*members);
    if (!fit.ok) return false;
    *centre = fit.centre;
    r = fit.radius_mm;
    band = o.inlier_band_mm;
  }
  members->clear();
  for (const auto& p : pts) {
    if (std::abs((p - *centre).norm() - r) < band) members->push_back(p);
  }
  return true;
}

}  // namespace

SphereFit FitSphere(const Points& points) {
  SphereFit fit;
  if (!AlgebraicSphere(points, &fit.centre, &fit.radius_mm)) return fit;
  for (fit.iterations = 1; fit.iterations <= 20; ++fit.iterations) {
    Eigen::Matrix4d h = Eigen::Matrix4d::Zero();
    Eigen::Vector4d g = Eigen::Vector4d::Zero();
    for (const auto& p : points) {
      const Eigen::Vector3d d = p - fit.centre;
      const double n = d.norm();
      if (n == 0) continue;
      Eigen::Vector4d j;
      j << -d / n, -1.0;
      const double r = n - fit.radius_mm;
      h += j * j.transpose();
      g += j * r;
    }
    const Eigen::Vector4d step = h.ldlt().solve(-g);
    if (!step.allFinite()) return SphereFit();
    fit.centre += step.head<3>();
    fit.radius_mm += step(3);
    if (step.norm() < 1e-12 * (1 + fit.radius_mm)) break;
  }
  fit.rms_mm = Rms(RadialResiduals(points, fit.centre, fit.radius_mm));
  fit.ok = fit.radius_mm > 0 && std::isfinite(fit.rms_mm);
  return fit;
}

PlaneFit FitPlane(const Points& points) {
  PlaneFit fit;
  if (points.size() < 3) return fit;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : points) mean += p;
  mean /= static_cast<double>(points.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : points) cov += (p - mean) * (p - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  if (!(eig.eigenvalues()(1) > 1e-12 * eig.eigenvalues()(2))) return fit;
  fit.normal = eig.eigenvectors().col(0).normalized();
  fit.centroid = mean;
  fit.rms_mm = std::sqrt(std::max(eig.eigenvalues()(0), 0.0) / points.size());
  fit.ok = true;
  return fit;
}

std::vector<size_t> KeepAfterDiscard(const std::vector<double>& residuals, double fraction) {
  const size_t n = residuals.size();
  std::vector<size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](size_t a, size_t b) { return residuals[a] < residuals[b]; });
  const size_t k = std::min(n, static_cast<size_t>(std::floor(fraction * n)));
  if (n == 0 || k == 0) return order;
  size_t best_low = 0;
  double best_range = std::numeric_limits<double>::infinity();
  for (size_t low = 0; low <= k; ++low) {
    const size_t high = k - low;  // removed from the top
    if (low + high >= n) break;
    const double range = residuals[order[n - 1 - high]] - residuals[order[low]];
    if (range < best_range) {
      best_range = range;
      best_low = low;
    }
  }
  return std::vector<size_t>(order.begin() + best_low, order.end() - (k - best_low));
}

void VdiOptions::Check() const {
  using util::CheckOption;
  const char* k = "VdiOptions";
  CheckOption(discard_fraction >= 0 && discard_fraction <= 0.003, k, "discard_fraction",
              discard_fraction, "must be in [0, 0.003] (VDI/VDE 2634-2 allows 0.3 %)");
  CheckOption(inlier_band_mm > 0, k, "inlier_band_mm", inlier_band_mm, "must be > 0");
  CheckOption(ransac_iterations >= 1, k, "ransac_iterations", ransac_iterations, "must be >= 1");
  CheckOption(ransac_sample_points >= 100, k, "ransac_sample_points", ransac_sample_points,
              "must be >= 100");
  CheckOption(radius_tolerance > 0 && radius_tolerance < 1, k, "radius_tolerance", radius_tolerance,
              "must be in (0, 1)");
  CheckOption(min_points >= 10, k, "min_points", min_points, "must be >= 10");
  CheckOption(min_cap_half_angle_deg > 0 && min_cap_half_angle_deg < 90, k,
              "min_cap_half_angle_deg", min_cap_half_angle_deg, "must be in (0, 90)");
  CheckOption(max_diameter_mm >= 0, k, "max_diameter_mm", max_diameter_mm,
              "must be >= 0 (0: the cloud's extent)");
}

const char* ToString(VdiStatus s) {
  switch (s) {
    case VdiStatus::kOk:
      return "ok";
    case VdiStatus::kTooFewPoints:
      return "too few points";
    case VdiStatus::kNotFound:
      return "artefact not found";
  }
  return "?";
}

std::string SphereResult::BriefReport() const {
  if (!ok()) return util::StrCat("sphere: ", ToString(status), ": ", message);
  const std::string ps = has_size_error() ? util::StrCat("PS ", PS_mm, " mm")
                                          : std::string("PS not measured (no calibrated diameter)");
  return util::StrCat("sphere: PF ", PF_mm, " mm, ", ps, " (diameter ", diameter_mm, " mm, RMS ",
                      rms_mm, " mm, ", points, " points, ", discarded, " left out)");
}

std::string BallBarResult::BriefReport() const {
  if (!ok()) return util::StrCat("ball bar: ", ToString(status), ": ", message);
  return util::StrCat("ball bar: SD ", SD_mm, " mm (distance ", distance_mm, " mm; ",
                      sphere_a.points, " + ", sphere_b.points, " points)");
}

std::string PlaneResult::BriefReport() const {
  if (!ok()) return util::StrCat("plane: ", ToString(status), ": ", message);
  return util::StrCat("plane: F ", F_mm, " mm (RMS ", rms_mm, " mm, ", points, " points, ",
                      discarded, " left out)");
}

SphereResult SphereFigures(const Points& points, double diameter_mm, double discard_fraction) {
  SphereResult out;
  SphereFit fit = FitSphere(points);
  if (!fit.ok) {
    out.status = VdiStatus::kTooFewPoints;
    out.message = util::StrCat(points.size(), " points do not define a sphere");
    return out;
  }
  const auto keep =
      KeepAfterDiscard(RadialResiduals(points, fit.centre, fit.radius_mm), discard_fraction);
  const Points kept = Select(points, keep);
  fit = FitSphere(kept);
  const std::vector<double> res = RadialResiduals(kept, fit.centre, fit.radius_mm);
  out.status = VdiStatus::kOk;
  out.centre = fit.centre;
  out.diameter_mm = 2 * fit.radius_mm;
  out.PF_mm = Range(res);
  out.calibrated_diameter_mm = std::max(0.0, diameter_mm);
  out.PS_mm = out.has_size_error() ? out.diameter_mm - diameter_mm : 0.0;
  out.rms_mm = Rms(res);
  out.points = static_cast<int>(kept.size());
  out.discarded = static_cast<int>(points.size() - kept.size());
  return out;
}

PlaneResult PlaneFigures(const Points& points, double discard_fraction) {
  PlaneResult out;
  PlaneFit fit = FitPlane(points);
  if (!fit.ok) {
    out.status = VdiStatus::kTooFewPoints;
    out.message = util::StrCat(points.size(), " points do not define a plane");
    return out;
  }
  auto distances = [](const Points& pts, const PlaneFit& f) {
    std::vector<double> d(pts.size());
    for (size_t i = 0; i < pts.size(); ++i) d[i] = f.normal.dot(pts[i] - f.centroid);
    return d;
  };
  const Points kept = Select(points, KeepAfterDiscard(distances(points, fit), discard_fraction));
  fit = FitPlane(kept);
  const std::vector<double> d = distances(kept, fit);
  out.status = VdiStatus::kOk;
  out.normal = fit.normal;
  out.F_mm = Range(d);
  out.rms_mm = Rms(d);
  out.points = static_cast<int>(kept.size());
  out.discarded = static_cast<int>(points.size() - kept.size());
  return out;
}

namespace {

// The sphere with most inliers: of nominal diameter search_diameter_mm, or a free radius when
// that is <= 0. calibrated_diameter_mm (<= 0: none) gives PS and bounds the fitted diameter.
SphereResult FindAndEvaluateSphere(const Points& pts, const Points& normals,
                                   double search_diameter_mm, double calibrated_diameter_mm,
                                   const VdiOptions& o, uint64_t stream) {
  SphereResult out;
  out.calibrated_diameter_mm = std::max(0.0, calibrated_diameter_mm);
  if (static_cast<int>(pts.size()) < o.min_points) {
    out.status = VdiStatus::kTooFewPoints;
    out.message = util::StrCat(pts.size(), " points, at least ", o.min_points, " needed");
    return out;
  }
  Eigen::Vector3d centre;
  double r0 = 0.5 * search_diameter_mm;
  Points members;
  const bool found = search_diameter_mm > 0 ? FindSphere(pts, normals, r0, o, stream, &centre)
                                            : FindSphereFreeRadius(pts, o, stream, &centre, &r0);
  if (!found || !RefineSphere(pts, r0, o, &centre, &members)) {
    out.message = search_diameter_mm > 0
                      ? util::StrCat("no sphere of diameter ", search_diameter_mm, " mm found")
                      : util::StrCat("no sphere seen over a cap of at least ",
                                     o.min_cap_half_angle_deg, " degrees found");
    return out;
  }
  if (static_cast<int>(members.size()) < o.min_points) {
    out.status = VdiStatus::kTooFewPoints;
    out.message = util::StrCat("sphere found with only ", members.size(), " points");
    return out;
  }
  out = SphereFigures(members, calibrated_diameter_mm, o.discard_fraction);
  const double nominal = calibrated_diameter_mm > 0 ? calibrated_diameter_mm : search_diameter_mm;
  if (out.ok() && nominal > 0 &&
      std::abs(out.diameter_mm - nominal) > o.radius_tolerance * nominal) {
    out.status = VdiStatus::kNotFound;
    out.message =
        util::StrCat("fitted diameter ", out.diameter_mm, " mm is far from ", nominal, " mm");
  }
  return out;
}

}  // namespace

SphereResult EvaluateSphere(const PointCloud& cloud, double diameter_mm,
                            const VdiOptions& options) {
  options.Check();
  util::CheckOption(std::isfinite(diameter_mm), "EvaluateSphere", "diameter_mm", diameter_mm,
                    "must be finite (<= 0: no calibrated diameter)");
  Points normals;
  const Points pts = FinitePoints(cloud, cloud.has_normals() ? &normals : nullptr);
  return FindAndEvaluateSphere(pts, normals, diameter_mm, diameter_mm, options, 0);
}

BallBarResult EvaluateBallBar(const PointCloud& cloud, double diameter_mm,
                              double calibrated_distance_mm, const VdiOptions& options) {
  options.Check();
  util::CheckOption(std::isfinite(diameter_mm), "EvaluateBallBar", "diameter_mm", diameter_mm,
                    "must be finite (<= 0: no calibrated diameter)");
  util::CheckOption(calibrated_distance_mm > std::max(0.0, diameter_mm), "EvaluateBallBar",
                    "calibrated_distance_mm", calibrated_distance_mm,
                    "must be positive and exceed the sphere diameter");
  BallBarResult out;
  Points normals;
  Points pts = FinitePoints(cloud, cloud.has_normals() ? &normals : nullptr);
  SphereResult first = FindAndEvaluateSphere(pts, normals, diameter_mm, diameter_mm, options, 0);
  if (!first.ok()) {
    out.status = first.status;
    out.message = "first sphere: " + first.message;
    out.sphere_a = std::move(first);
    return out;
  }
  // Remove the first sphere (and what touches it) before looking for the second, and look only
  // where the second can be: its surface lies within the calibrated distance +- its radius (and
  // a 5 % tolerance) of the first centre. Without this, another sphere in the scene (a VDI
  // sphere of a different diameter beside the bar) can capture the search. Without a calibrated
  // diameter the second sphere is searched with the first one's fitted diameter.
  const double search_diameter_mm = diameter_mm > 0 ? diameter_mm : first.diameter_mm;
  if (!(calibrated_distance_mm > search_diameter_mm)) {
    out.status = VdiStatus::kNotFound;
    out.message = util::StrCat("first sphere's fitted diameter ", first.diameter_mm,
                               " mm is not below the calibrated distance");
    out.sphere_a = std::move(first);
    return out;
  }
  Points rest, rest_normals;
  const double clear_mm = 0.5 * search_diameter_mm + 4 * options.inlier_band_mm;
  const double shell_mm = 0.5 * search_diameter_mm + 0.05 * calibrated_distance_mm;
  for (size_t i = 0; i < pts.size(); ++i) {
    const double d = (pts[i] - first.centre).norm();
    if (d < clear_mm || std::abs(d - calibrated_distance_mm) > shell_mm) continue;
    rest.push_back(pts[i]);
    if (!normals.empty()) rest_normals.push_back(normals[i]);
  }
  SphereResult second =
      FindAndEvaluateSphere(rest, rest_normals, search_diameter_mm, diameter_mm, options, 1);
  if (!second.ok()) {
    out.status = second.status;
    out.message = "second sphere: " + second.message;
    out.sphere_a = std::move(first);
    out.sphere_b = std::move(second);
    return out;
  }
  // Labels by position (see BallBarResult).
  const Eigen::Vector3d delta = second.centre - first.centre;
  int axis = 0;
  delta.cwiseAbs().maxCoeff(&axis);
  if (delta(axis) < 0) std::swap(first, second);
  out.sphere_a = std::move(first);
  out.sphere_b = std::move(second);
  out.status = VdiStatus::kOk;
  out.distance_mm = (out.sphere_a.centre - out.sphere_b.centre).norm();
  out.SD_mm = out.distance_mm - calibrated_distance_mm;
  return out;
}

PlaneResult EvaluatePlane(const PointCloud& cloud, const VdiOptions& options) {
  options.Check();
  PlaneResult out;
  Points normals;
  const Points pts = FinitePoints(cloud, cloud.has_normals() ? &normals : nullptr);
  if (static_cast<int>(pts.size()) < options.min_points) {
    out.status = VdiStatus::kTooFewPoints;
    out.message = util::StrCat(pts.size(), " points, at least ", options.min_points, " needed");
    return out;
  }
  util::Rng rng(util::MixSeed(options.seed, 7));
  const std::vector<size_t> sample = Subsample(pts.size(), options.ransac_sample_points, rng);
  std::uniform_int_distribution<size_t> pick(0, sample.size() - 1);
  int best_score = 0;
  Eigen::Vector3d best_n = Eigen::Vector3d::UnitZ(), best_p = pts[0];
  for (int it = 0; it < options.ransac_iterations; ++it) {
    const Eigen::Vector3d p0 = pts[sample[pick(rng)]];
    const Eigen::Vector3d p1 = pts[sample[pick(rng)]], p2 = pts[sample[pick(rng)]];
    Eigen::Vector3d n = (p1 - p0).cross(p2 - p0);
    if (n.norm() < 1e-9) continue;
    n.normalize();
    int score = 0;
    for (size_t j : sample) score += std::abs(n.dot(pts[j] - p0)) < options.inlier_band_mm;
    if (score > best_score) {
      best_score = score;
      best_n = n;
      best_p = p0;
    }
  }
  Points members;
  for (int pass = 0; pass < 3; ++pass) {
    members.clear();
    for (const auto& p : pts) {
      if (std::abs(best_n.dot(p - best_p)) < options.inlier_band_mm) members.push_back(p);
    }
    const PlaneFit fit = FitPlane(members);
    if (!fit.ok) break;
    best_n = fit.normal;
    best_p = fit.centroid;
  }
  if (static_cast<int>(members.size()) < options.min_points) {
    out.status = VdiStatus::kNotFound;
    out.message = util::StrCat("largest plane has only ", members.size(), " points");
    return out;
  }
  return PlaneFigures(members, options.discard_fraction);
}

nlohmann::json ToJson(const SphereResult& r) {
  nlohmann::json j = {{"status", ToString(r.status)}, {"message", r.message}};
  if (r.ok()) {
    // PS_mm only when a calibrated diameter was given (it would be a made-up 0 otherwise).
    if (r.has_size_error()) {
      j.update({{"PS_mm", r.PS_mm}, {"calibrated_diameter_mm", r.calibrated_diameter_mm}});
    }
    j.update({{"PF_mm", r.PF_mm},
              {"diameter_mm", r.diameter_mm},
              {"centre_mm", {r.centre.x(), r.centre.y(), r.centre.z()}},
              {"rms_mm", r.rms_mm},
              {"points", r.points},
              {"discarded", r.discarded}});
  }
  return j;
}

nlohmann::json ToJson(const BallBarResult& r) {
  nlohmann::json j = {{"status", ToString(r.status)},
                      {"message", r.message},
                      {"sphere_a", ToJson(r.sphere_a)},
                      {"sphere_b", ToJson(r.sphere_b)}};
  if (r.ok()) {
    j["SD_mm"] = r.SD_mm;
    j["distance_mm"] = r.distance_mm;
  }
  return j;
}

nlohmann::json ToJson(const PlaneResult& r) {
  nlohmann::json j = {{"status", ToString(r.status)}, {"message", r.message}};
  if (r.ok()) {
    j.update({{"F_mm", r.F_mm},
              {"normal", {r.normal.x(), r.normal.y(), r.normal.z()}},
              {"rms_mm", r.rms_mm},
              {"points", r.points},
              {"discarded", r.discarded}});
  }
  return j;
}

}  // namespace fringe::eval
