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
  IcpSchedule::Check(o);
  util::CheckOption(trim_fraction > 0 && trim_fraction <= 1, o, "trim_fraction", trim_fraction,
                    "must be in (0, 1]");
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

MeshAlignResult AlignToMesh(const PointCloud& cloud, const MeshIndex& mesh,
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
  std::string no_overlap;
  const auto iterate = [&](int points, double threshold, IcpLevelReport* rep) {
    IcpIteration out;
    const int ns = std::min<int>(points, order.size());
    rep->points_per_view = ns;
    rep->overlapping_pairs = 1;
    std::vector<Sample> s(ns);
    tbb::parallel_for(0, ns, [&](int k) {
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
      no_overlap = StrCat("only ", d.size(), " of ", s.size(), " samples lie within ", threshold,
                          " mm of the mesh");
      return out;
    }
    out.overlap = true;
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
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(6, 6);
    Eigen::VectorXd g = Eigen::VectorXd::Zero(6);
    double ss = 0, lever_sq = 0;
    for (const Sample& x : s) {
      if (!x.ok || x.r > cut) continue;
      out.residuals_mm.push_back(x.r);
      lever_sq += (x.p - centroid).squaredNorm();
      if (x.n.isZero()) continue;  // on the surface: residual 0, no gradient
      Eigen::Matrix<double, 6, 1> j;
      j << (x.p - centroid).cross(x.n), x.n;
      H += j * j.transpose();
      g += j * x.r;
      ss += x.r * x.r;
    }
    out.rms_mm = std::sqrt(ss / n);
    rep->correspondences = n;
    result.rms_mm = out.rms_mm;
    result.correspondences = n;
    if (ss == 0) return out;  // every kept sample lies on the surface: nothing left to move
    // Directions the kept points do not constrain (all on planes and cylinders sharing a
    // direction) are not moved.
    const double lever = std::max(1.0, std::sqrt(lever_sq / n));
    const IcpStep step = DegeneracyAwareStep(H, g, lever, options.degeneracy_ratio, out.rms_mm);
    rep->degenerate_directions = step.degenerate;
    out.step_sigmas = step.step_sigmas;
    const Vector3d w = step.delta.head<3>();
    const double angle = w.norm();
    const Rigid3d rot = angle > 0 ? Rigid3d::FromAxisAngle(w / angle, angle) : Rigid3d();
    pose =
        Rigid3d(rot.rotation(), centroid + step.delta.tail<3>() - rot.RotateDirection(centroid)) *
        pose;
    out.step_rotation_deg = angle * 180 / M_PI;
    out.step_translation_mm = step.delta.tail<3>().norm();
    return out;
  };
  switch (RunIcpSchedule(options, iterate, &result.levels)) {
    case IcpScheduleOutcome::kConverged:
      result.status = IcpStatus::kOk;
      break;
    case IcpScheduleOutcome::kNotConverged:
      result.status = IcpStatus::kNotConverged;
      result.message = "a level stopped at its iteration limit";
      break;
    case IcpScheduleOutcome::kNoOverlap:
      result.status = IcpStatus::kNoOverlap;
      result.message = no_overlap;
      break;
  }
  result.seconds = timer.ElapsedSeconds();
  return result;
}

}  // namespace fringe::registration
