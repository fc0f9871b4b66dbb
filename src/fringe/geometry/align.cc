#include "fringe/geometry/align.h"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <cmath>

#include "fringe/util/error.h"

namespace fringe {

RigidAlignment AlignRigid(const std::vector<Eigen::Vector3d>& p_in_a,
                          const std::vector<Eigen::Vector3d>& p_in_b,
                          const std::vector<double>& weights) {
  if (p_in_a.size() != p_in_b.size()) {
    throw Error(util::StrCat("AlignRigid: ", p_in_a.size(), " source points but ", p_in_b.size(),
                             " target points"));
  }
  if (!weights.empty() && weights.size() != p_in_a.size()) {
    throw Error(util::StrCat("AlignRigid: ", weights.size(), " weights for ", p_in_a.size(),
                             " point pairs"));
  }
  RigidAlignment result;
  const size_t n = p_in_a.size();
  double w_sum = 0;
  int n_used = 0;
  Eigen::Vector3d mean_a = Eigen::Vector3d::Zero(), mean_b = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    const double w = weights.empty() ? 1.0 : weights[i];
    if (!(w >= 0))
      throw Error(util::StrCat("AlignRigid: weight ", i, " is ", w, " (must be >= 0)"));
    if (w == 0) continue;
    ++n_used;
    w_sum += w;
    mean_a += w * p_in_a[i];
    mean_b += w * p_in_b[i];
  }
  result.num_points = n_used;
  if (n_used < 3) {
    result.status = RigidAlignment::Status::kTooFewPoints;
    result.message = util::StrCat(n_used, " point pairs (at least 3 needed)");
    return result;
  }
  mean_a /= w_sum;
  mean_b /= w_sum;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d scatter_a = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    const double w = weights.empty() ? 1.0 : weights[i];
    if (w == 0) continue;
    const Eigen::Vector3d da = p_in_a[i] - mean_a;
    cov += w * (p_in_b[i] - mean_b) * da.transpose();
    scatter_a += w * da * da.transpose();
  }
  // Collinear (or coincident) source points leave the rotation about their line free: the second
  // largest spread must be a meaningful fraction of the largest.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> spread(scatter_a);
  const Eigen::Vector3d ev = spread.eigenvalues();  // ascending
  if (ev(2) <= 0 || ev(1) <= 1e-10 * ev(2)) {
    result.status = RigidAlignment::Status::kDegenerate;
    result.message = "points are collinear or coincident: rotation is undetermined";
    return result;
  }
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d s = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) s(2, 2) = -1;
  const Eigen::Matrix3d r = svd.matrixU() * s * svd.matrixV().transpose();
  result.b_from_a = Rigid3d(r, mean_b - r * mean_a);
  double sq = 0;
  for (size_t i = 0; i < n; ++i) {
    const double w = weights.empty() ? 1.0 : weights[i];
    sq += w * (result.b_from_a * p_in_a[i] - p_in_b[i]).squaredNorm();
  }
  result.rms_mm = std::sqrt(sq / w_sum);
  result.status = RigidAlignment::Status::kOk;
  result.message = "ok";
  return result;
}

}  // namespace fringe
