#include "fringe/stereo/projector_columns.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>

#include "fringe/util/error.h"

namespace fringe::stereo {

using Vec3 = Eigen::Vector3d;
using Vec4 = Eigen::Vector4d;

double ProjectorColumnModel::Column(const Vec3& p) const {
  const Vec4 x = p.homogeneous();
  const double den = rows.row(1).dot(x);
  if (!(den > 0)) return std::numeric_limits<double>::quiet_NaN();
  return rows.row(0).dot(x) / den;
}

void ProjectorColumnFitOptions::Check() const {
  using util::CheckOption;
  const char* o = "ProjectorColumnFitOptions";
  CheckOption(min_points >= 8, o, "min_points", min_points, "must be >= 8");
  CheckOption(rounds >= 1 && rounds <= 20, o, "rounds", rounds, "must be in [1, 20]");
  CheckOption(max_error_px > 0, o, "max_error_px", max_error_px, "must be > 0");
  CheckOption(max_rms_px > 0, o, "max_rms_px", max_rms_px, "must be > 0");
  CheckOption(min_inlier_fraction > 0 && min_inlier_fraction <= 1, o, "min_inlier_fraction",
              min_inlier_fraction, "must be in (0, 1]");
  CheckOption(min_thickness > 0 && min_thickness < 1, o, "min_thickness", min_thickness,
              "must be in (0, 1)");
}

ProjectorColumnFit FitProjectorColumns(const std::vector<Vec3>& points,
                                       const std::vector<double>& columns,
                                       const ProjectorColumnFitOptions& options) {
  options.Check();
  if (points.size() != columns.size()) {
    throw Error(util::StrCat("FitProjectorColumns: ", points.size(), " points but ", columns.size(),
                             " columns"));
  }
  ProjectorColumnFit out;
  const size_t n = points.size();
  out.num_points = static_cast<int>(n);
  if (static_cast<int>(n) < options.min_points) {
    out.message = util::StrCat("only ", n, " points (need ", options.min_points, ")");
    return out;
  }
  // Hartley normalisation.
  Vec3 mean = Vec3::Zero();
  double mean_u = 0;
  for (size_t i = 0; i < n; ++i) {
    mean += points[i];
    mean_u += columns[i];
  }
  mean /= static_cast<double>(n);
  mean_u /= static_cast<double>(n);
  double dist = 0, dev_u = 0;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    const Vec3 d = points[i] - mean;
    dist += d.norm();
    dev_u += std::abs(columns[i] - mean_u);
    cov += d * d.transpose();
  }
  dist /= static_cast<double>(n);
  dev_u /= static_cast<double>(n);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> spread(cov / static_cast<double>(n));
  const Vec3 ev = spread.eigenvalues().cwiseMax(0);  // ascending
  out.thickness = ev(2) > 0 ? std::sqrt(ev(0) / ev(2)) : 0;
  if (!(dist > 0) || !(dev_u > 0) || out.thickness < options.min_thickness) {
    out.message = util::StrCat("the points are nearly coplanar (thickness ", out.thickness, " < ",
                               options.min_thickness, "): the columns are not determined");
    return out;
  }
  const double s = std::sqrt(3.0) / dist, su = 1.0 / dev_u;
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  t.topLeftCorner<3, 3>() *= s;
  t.topRightCorner<3, 1>() = -s * mean;

  std::vector<Vec4> xn(n);
  std::vector<double> un(n);
  for (size_t i = 0; i < n; ++i) {
    xn[i] = t * points[i].homogeneous();
    un[i] = su * (columns[i] - mean_u);
  }
  std::vector<uint8_t> use(n, 1);
  std::vector<double> weight(n, 1.0), err(n, 0.0);
  Eigen::Matrix<double, 8, 1> q = Eigen::Matrix<double, 8, 1>::Zero();
  auto residual = [&](size_t i) {
    const double den = q.tail<4>().dot(xn[i]);
    return std::abs(q.head<4>().dot(xn[i]) / den - un[i]) / su;  // projector pixels
  };
  for (int round = 0; round < options.rounds; ++round) {
    Eigen::Matrix<double, 8, 8> m = Eigen::Matrix<double, 8, 8>::Zero();
    int used = 0;
    for (size_t i = 0; i < n; ++i) {
      if (!use[i]) continue;
      Eigen::Matrix<double, 8, 1> row;
      row << xn[i], -un[i] * xn[i];
      m.noalias() += weight[i] * row * row.transpose();
      ++used;
    }
    if (used < options.min_points) {
      out.message = util::StrCat("only ", used, " points left after trimming (need ",
                                 options.min_points, ")");
      return out;
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 8, 8>> es(m);
    q = es.eigenvectors().col(0);
    // Points in front of the projector: c . x > 0 for most of them.
    std::vector<double> dens;
    dens.reserve(n);
    for (size_t i = 0; i < n; ++i) dens.push_back(q.tail<4>().dot(xn[i]));
    std::nth_element(dens.begin(), dens.begin() + n / 2, dens.end());
    if (dens[n / 2] < 0) q = -q;
    // Weights for the next round: the algebraic residual divided by c . x is the column error.
    for (size_t i = 0; i < n; ++i) {
      const double den = q.tail<4>().dot(xn[i]);
      weight[i] = den > 0 ? 1.0 / (den * den) : 0.0;
      err[i] = den > 0 ? residual(i) : std::numeric_limits<double>::infinity();
    }
    std::vector<double> sorted;
    sorted.reserve(n);
    for (size_t i = 0; i < n; ++i) {
      if (use[i]) sorted.push_back(err[i]);
    }
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double limit =
        std::max(0.25 * options.max_error_px, 4 * 1.4826 * sorted[sorted.size() / 2]);
    for (size_t i = 0; i < n; ++i) use[i] = err[i] <= limit ? 1 : 0;
  }
  double ss = 0;
  for (size_t i = 0; i < n; ++i) {
    if (err[i] > options.max_error_px) continue;
    ss += err[i] * err[i];
    ++out.num_inliers;
  }
  out.rms_px = out.num_inliers ? std::sqrt(ss / out.num_inliers) : 0;
  // Back to raw units: u = ((a_n / su + mean_u c_n) . T x) / (c_n . T x).
  const Vec4 a = q.head<4>() / su + mean_u * q.tail<4>();
  out.model.rows.row(0) = (a.transpose() * t);
  out.model.rows.row(1) = (q.tail<4>().transpose() * t);
  const double fraction = out.num_inliers / static_cast<double>(n);
  if (fraction < options.min_inlier_fraction) {
    out.message =
        util::StrCat("only ", 100 * fraction, " % of the points within ", options.max_error_px,
                     " px of the fitted columns (need ", 100 * options.min_inlier_fraction, " %)");
  } else if (!(out.rms_px <= options.max_rms_px)) {
    out.message = util::StrCat("column RMS ", out.rms_px, " px > ", options.max_rms_px,
                               " px (lens distortion, or phase not the projector column?)");
  } else {
    out.ok = true;
    out.message = util::StrCat("fitted to ", n, " points: ", out.num_inliers, " within ",
                               options.max_error_px, " px, RMS ", out.rms_px, " px");
  }
  return out;
}

namespace {

// The left phase must be CV_32F on the cloud's grid; `caller` names the function in the error.
void CheckPhaseGrid(const char* caller, const cv::Mat& phase, const OrganizedPointCloud& cloud) {
  if (phase.type() != CV_32F || phase.cols != cloud.width || phase.rows != cloud.height) {
    throw Error(util::StrCat(caller, ": phase ", phase.cols, " x ", phase.rows,
                             " (CV_32F expected) for a ", cloud.width, " x ", cloud.height,
                             " cloud"));
  }
}

}  // namespace

void SampleProjectorColumns(const OrganizedPointCloud& cloud, const cv::Mat& phase, int stride,
                            std::vector<Vec3>* points, std::vector<double>* columns) {
  CheckPhaseGrid("SampleProjectorColumns", phase, cloud);
  if (stride < 1) throw Error("SampleProjectorColumns: stride must be >= 1");
  int k = 0;
  for (size_t i = 0; i < cloud.valid.size(); ++i) {
    if (!cloud.valid[i]) continue;
    if (k++ % stride != 0) continue;
    const float u =
        phase.at<float>(static_cast<int>(i / cloud.width), static_cast<int>(i % cloud.width));
    if (!std::isfinite(u)) continue;
    points->push_back(cloud.cloud.points[i]);
    columns->push_back(u);
  }
}

int RejectByProjectorColumns(const ProjectorColumnModel& model, const cv::Mat& phase,
                             double max_error_px, OrganizedPointCloud* cloud) {
  CheckPhaseGrid("RejectByProjectorColumns", phase, *cloud);
  int removed = 0;
  for (size_t i = 0; i < cloud->valid.size(); ++i) {
    if (!cloud->valid[i]) continue;
    const float u =
        phase.at<float>(static_cast<int>(i / cloud->width), static_cast<int>(i % cloud->width));
    const double e = std::abs(model.Column(cloud->cloud.points[i]) - u);
    if (e <= max_error_px) continue;  // false for NaN: removed
    cloud->valid[i] = 0;
    ++removed;
  }
  return removed;
}

}  // namespace fringe::stereo
