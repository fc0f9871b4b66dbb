#include "fringe/registration/align_to_mesh.h"

#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "fringe/util/error.h"
#include "fringe/util/timer.h"

namespace fringe::registration {

using Eigen::Vector3d;
using util::StrCat;

void MeshAlignOptions::Check() const {
  const char* o = "MeshAlignOptions";
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
  util::CheckOption(degeneracy_ratio >= 0 && degeneracy_ratio < 1, o, "degeneracy_ratio",
                    degeneracy_ratio, "must be in [0, 1)");
  util::CheckOption(convergence_rotation_deg > 0, o, "convergence_rotation_deg",
                    convergence_rotation_deg, "must be > 0");
  util::CheckOption(convergence_translation_mm > 0, o, "convergence_translation_mm",
                    convergence_translation_mm, "must be > 0");
}

std::string MeshAlignResult::BriefReport() const {
  std::string s = StrCat("align to mesh: ", ToString(status), ", rms ", rms_mm, " mm over ",
                         correspondences, " points, ", seconds, " s");
  for (const IcpLevelReport& l : levels) {
    s += StrCat("; level ", l.level, " (", l.points_per_view, " pts): ", l.iterations, " it",
                l.converged ? "" : " (not converged)", ", threshold ", l.threshold_start_mm, " -> ",
                l.threshold_end_mm, " mm, rms ", l.rms_start_mm, " -> ", l.rms_end_mm, " mm");
  }
  if (!message.empty()) s += ": " + message;
  return s;
}

namespace {

struct Sample {
  bool ok = false;
  Vector3d p = Vector3d::Zero();  // moved point (mesh frame)
  Vector3d n = Vector3d::Zero();  // unit, from the closest surface point toward p
  double r = 0;                   // distance to the surface
};

}  // namespace

MeshAlignResult AlignToMesh(const PointCloud& cloud, const eval::MeshDistance& mesh,
                            const Rigid3d& mesh_from_cloud_start, const MeshAlignOptions& options) {
  options.Check();
  util::Timer timer;
  MeshAlignResult result;
  result.mesh_from_cloud = mesh_from_cloud_start;
  // With normals: normal-space sampling (icp.h), so that the few walls beside a large plane
  // take part from the first level on; without: a seeded random order.
  std::vector<uint32_t> usable;
  std::vector<Eigen::Vector3d> normals;
  const bool with_normals = cloud.normals.size() == cloud.size();
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (!cloud.points[i].allFinite()) continue;
    if (with_normals && !(cloud.normals[i].allFinite() && cloud.normals[i].norm() > 0.5)) continue;
    usable.push_back(static_cast<uint32_t>(i));
    if (with_normals) normals.push_back(cloud.normals[i]);
  }
  std::vector<uint32_t> order = usable;
  if (order.size() < 10) {
    result.message = StrCat("the cloud has ", order.size(), " finite points; at least 10 needed");
    result.seconds = timer.ElapsedSeconds();
    return result;
  }
  if (with_normals) {
    const std::vector<uint32_t> nss = NormalSpaceOrder(normals, options.seed);
    for (size_t k = 0; k < nss.size(); ++k) order[k] = usable[nss[k]];
  } else {
    std::mt19937_64 rng(options.seed);
    std::shuffle(order.begin(), order.end(), rng);
  }
  Rigid3d& pose = result.mesh_from_cloud;
  double threshold = options.initial_threshold_mm;
  bool all_converged = true;
  for (size_t level = 0; level < options.points_per_level.size(); ++level) {
    IcpLevelReport rep;
    rep.level = static_cast<int>(level);
    rep.points_per_view = std::min<int>(options.points_per_level[level], order.size());
    rep.threshold_start_mm = threshold;
    rep.overlapping_pairs = 1;
    std::vector<double> last;
    for (int it = 0; it < options.max_iterations_per_level; ++it) {
      std::vector<Sample> s(rep.points_per_view);
      tbb::parallel_for(0, rep.points_per_view, [&](int k) {
        Sample& x = s[k];
        x.p = pose * cloud.points[order[k]];
        Vector3d q;
        const double d = mesh.SignedDistance(x.p, threshold, &q);
        if (!std::isfinite(d)) return;
        const Vector3d e = x.p - q;
        x.r = e.norm();
        if (x.r > threshold) return;
        // A point on the surface (to rounding) is matched with no residual and no direction.
        if (x.r >= 1e-12) x.n = e / x.r;
        x.ok = true;
      });
      std::vector<double> d;
      for (const Sample& x : s) {
        if (x.ok) d.push_back(x.r);
      }
      if (d.size() < 6) {
        result.status = IcpStatus::kNoOverlap;
        result.message = StrCat("only ", d.size(), " of ", s.size(), " samples lie within ",
                                threshold, " mm of the mesh");
        result.levels.push_back(rep);
        result.seconds = timer.ElapsedSeconds();
        return result;
      }
      const size_t keep = std::max<size_t>(6, std::floor(options.trim_fraction * d.size()));
      double cut = threshold;
      if (keep < d.size()) {
        std::vector<double> sorted = d;
        std::nth_element(sorted.begin(), sorted.begin() + (keep - 1), sorted.end());
        cut = sorted[keep - 1];
      }
      Vector3d centroid = Vector3d::Zero();
      int n = 0;
      for (const Sample& x : s) {
        if (x.ok && x.r <= cut) {
          centroid += x.p;
          ++n;
        }
      }
      centroid /= n;
      Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
      Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
      double ss = 0;
      std::vector<double> kept;
      for (const Sample& x : s) {
        if (!x.ok || x.r > cut) continue;
        kept.push_back(x.r);
        if (x.n.isZero()) continue;  // on the surface: residual 0, no gradient
        Eigen::Matrix<double, 6, 1> j;
        j << (x.p - centroid).cross(x.n), x.n;
        H += j * j.transpose();
        g += j * x.r;
        ss += x.r * x.r;
      }
      const double rms = std::sqrt(ss / n);
      if (it == 0) rep.rms_start_mm = rms;
      rep.rms_end_mm = rms;
      rep.correspondences = n;
      result.rms_mm = rms;
      result.correspondences = n;
      last.swap(kept);
      if (ss == 0) {  // every kept sample lies on the surface: nothing left to move
        rep.iterations = it + 1;
        rep.converged = true;
        break;
      }
      // Directions the kept points do not constrain (all on planes and cylinders sharing a
      // direction) are not moved: eigen-decomposition of the normal matrix with the rotations
      // scaled by the points' RMS lever, as in icp.cc.
      double lever_sq = 0;
      for (const Sample& x : s) {
        if (x.ok && x.r <= cut) lever_sq += (x.p - centroid).squaredNorm();
      }
      const double lever = std::max(1.0, std::sqrt(lever_sq / n));
      Eigen::Matrix<double, 6, 1> scale = Eigen::Matrix<double, 6, 1>::Ones();
      scale.head<3>().setConstant(1.0 / lever);
      const Eigen::Matrix<double, 6, 6> Hs = scale.asDiagonal() * H * scale.asDiagonal();
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(Hs);
      const double lmax = eig.eigenvalues().maxCoeff();
      Eigen::Matrix<double, 6, 1> ds = Eigen::Matrix<double, 6, 1>::Zero();
      int degenerate = 0;
      for (int k = 0; k < 6; ++k) {
        const double l = eig.eigenvalues()[k];
        if (!(l > options.degeneracy_ratio * lmax)) {
          ++degenerate;
          continue;
        }
        ds -=
            eig.eigenvectors().col(k) * (eig.eigenvectors().col(k).dot(scale.cwiseProduct(g)) / l);
      }
      rep.degenerate_directions = degenerate;
      const Eigen::Matrix<double, 6, 1> delta = scale.cwiseProduct(ds);
      const Vector3d w = delta.head<3>();
      const double angle = w.norm();
      const Rigid3d rot = angle > 0 ? Rigid3d::FromAxisAngle(w / angle, angle) : Rigid3d();
      const Rigid3d step(rot.rotation(),
                         centroid + delta.tail<3>() - rot.RotateDirection(centroid));
      pose = step * pose;
      rep.iterations = it + 1;
      if (angle * 180 / M_PI < options.convergence_rotation_deg &&
          delta.tail<3>().norm() < options.convergence_translation_mm) {
        rep.converged = true;
        break;
      }
    }
    if (!last.empty()) {
      const size_t q =
          std::min(last.size() - 1, static_cast<size_t>(options.shrink_percentile * last.size()));
      std::nth_element(last.begin(), last.begin() + q, last.end());
      threshold =
          std::max(options.min_threshold_mm, std::min(threshold, options.shrink_factor * last[q]));
    }
    rep.threshold_end_mm = threshold;
    all_converged &= rep.converged;
    result.levels.push_back(rep);
  }
  result.status = all_converged ? IcpStatus::kOk : IcpStatus::kNotConverged;
  if (!all_converged) result.message = "a level stopped at its iteration limit";
  result.seconds = timer.ElapsedSeconds();
  return result;
}

}  // namespace fringe::registration
