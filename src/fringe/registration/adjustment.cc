#include "fringe/registration/adjustment.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <cmath>

#include "fringe/util/error.h"
#include "fringe/util/timer.h"

namespace fringe::registration {

using util::StrCat;

void AdjustmentOptions::Check() const {
  util::CheckOption(huber_sigmas > 0, "AdjustmentOptions", "huber_sigmas", huber_sigmas,
                    "must be > 0");
  util::CheckOption(max_iterations >= 1, "AdjustmentOptions", "max_iterations", max_iterations,
                    "must be >= 1");
}

const char* ToString(AdjustmentStatus s) {
  switch (s) {
    case AdjustmentStatus::kOk:
      return "ok";
    case AdjustmentStatus::kNotConverged:
      return "not converged";
    case AdjustmentStatus::kNothingToAdjust:
      return "nothing to adjust";
  }
  return "?";
}

std::string AdjustmentSummary::BriefReport() const {
  std::string s =
      StrCat("marker adjustment: ", ToString(status), ", ", views, " views, ", markers,
             " markers, ", observations, " observations, rms ", rms_initial_mm, " -> ",
             rms_final_mm, " mm (max ", max_final_mm, " mm), ", iterations, " iterations");
  if (!message.empty()) s += ": " + message;
  return s;
}

namespace {

struct SightingCost {
  // sqrt_info: L^T with L L^T = C^-1 (so that |L^T e|^2 = e^T C^-1 e).
  SightingCost(const Eigen::Vector3d& x, const Eigen::Matrix3d& sqrt_info)
      : x_(x), sqrt_info_(sqrt_info) {}
  template <typename T>
  bool operator()(const T* aa, const T* t, const T* marker, T* residual) const {
    // e_sensor = x - R^T (X - t): the sighting's error in its own sensor frame.
    const T d[3] = {marker[0] - t[0], marker[1] - t[1], marker[2] - t[2]};
    const T minus_aa[3] = {-aa[0], -aa[1], -aa[2]};
    T back[3];
    ceres::AngleAxisRotatePoint(minus_aa, d, back);
    T e[3];
    for (int i = 0; i < 3; ++i) e[i] = T(x_[i]) - back[i];
    for (int i = 0; i < 3; ++i) {
      residual[i] =
          T(sqrt_info_(i, 0)) * e[0] + T(sqrt_info_(i, 1)) * e[1] + T(sqrt_info_(i, 2)) * e[2];
    }
    return true;
  }
  Eigen::Vector3d x_;
  Eigen::Matrix3d sqrt_info_;
};

Eigen::Matrix3d SqrtInformation(const MarkerSighting& o) {
  const Eigen::Matrix3d c =
      o.covariance_in_sensor.isZero(0)
          ? Eigen::Matrix3d(Eigen::Matrix3d::Identity() * o.sigma_mm * o.sigma_mm / 3)
          : o.covariance_in_sensor;
  const Eigen::LLT<Eigen::Matrix3d> llt(c.inverse());
  return llt.matrixL().transpose();
}

void Residuals(const std::vector<Rigid3d>& poses, const std::vector<Eigen::Vector3d>& markers,
               const std::vector<MarkerSighting>& s, double* rms, double* max) {
  double ss = 0;
  *max = 0;
  for (const MarkerSighting& o : s) {
    const double d = (poses[o.view] * o.centre_in_sensor - markers[o.marker]).norm();
    ss += d * d;
    *max = std::max(*max, d);
  }
  *rms = s.empty() ? 0 : std::sqrt(ss / s.size());
}

}  // namespace

AdjustmentResult AdjustMarkers(const std::vector<Rigid3d>& world_from_sensor,
                               const std::vector<Eigen::Vector3d>& markers_in_world,
                               const std::vector<MarkerSighting>& sightings,
                               const std::vector<bool>& view_fixed,
                               const AdjustmentOptions& options) {
  options.Check();
  util::Timer timer;
  const int nv = static_cast<int>(world_from_sensor.size());
  const int nm = static_cast<int>(markers_in_world.size());
  if (static_cast<int>(view_fixed.size()) != nv) {
    throw Error("AdjustMarkers: view_fixed needs one flag per view");
  }
  for (const MarkerSighting& o : sightings) {
    const bool cov_ok =
        o.covariance_in_sensor.isZero(0) ||
        (o.covariance_in_sensor.allFinite() &&
         Eigen::LLT<Eigen::Matrix3d>(o.covariance_in_sensor).info() == Eigen::Success);
    if (o.view < 0 || o.view >= nv || o.marker < 0 || o.marker >= nm || !(o.sigma_mm > 0) ||
        !o.centre_in_sensor.allFinite() || !cov_ok) {
      throw Error(StrCat("AdjustMarkers: bad sighting (view ", o.view, ", marker ", o.marker,
                         ", sigma ", o.sigma_mm, ")"));
    }
  }
  AdjustmentResult r;
  r.world_from_sensor = world_from_sensor;
  r.markers_in_world = markers_in_world;
  AdjustmentSummary& s = r.summary;
  s.views = nv;
  s.markers = nm;
  s.observations = static_cast<int>(sightings.size());
  Residuals(r.world_from_sensor, r.markers_in_world, sightings, &s.rms_initial_mm, &s.max_final_mm);
  if (sightings.empty()) {
    s.status = AdjustmentStatus::kNothingToAdjust;
    s.message = "no marker sightings";
    return r;
  }
  std::vector<std::array<double, 3>> aa(nv), t(nv);
  for (int v = 0; v < nv; ++v) {
    const Eigen::AngleAxisd a(world_from_sensor[v].rotation());
    const Eigen::Vector3d w = a.angle() * a.axis();
    aa[v] = {w.x(), w.y(), w.z()};
    const Eigen::Vector3d& tr = world_from_sensor[v].translation();
    t[v] = {tr.x(), tr.y(), tr.z()};
  }
  std::vector<std::array<double, 3>> X(nm);
  for (int k = 0; k < nm; ++k) {
    X[k] = {markers_in_world[k].x(), markers_in_world[k].y(), markers_in_world[k].z()};
  }
  ceres::Problem problem;
  for (const MarkerSighting& o : sightings) {
    auto* cost = new ceres::AutoDiffCostFunction<SightingCost, 3, 3, 3, 3>(
        new SightingCost(o.centre_in_sensor, SqrtInformation(o)));
    problem.AddResidualBlock(cost, new ceres::HuberLoss(options.huber_sigmas), aa[o.view].data(),
                             t[o.view].data(), X[o.marker].data());
  }
  bool any_fixed = false;
  for (int v = 0; v < nv; ++v) any_fixed |= view_fixed[v];
  for (int v = 0; v < nv; ++v) {
    if (!problem.HasParameterBlock(aa[v].data())) continue;
    if (view_fixed[v] || (!any_fixed && v == 0)) {
      problem.SetParameterBlockConstant(aa[v].data());
      problem.SetParameterBlockConstant(t[v].data());
    }
  }
  ceres::Solver::Options so;
  so.linear_solver_type =
      ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE) ||
              ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::EIGEN_SPARSE)
          ? ceres::SPARSE_NORMAL_CHOLESKY
          : ceres::DENSE_QR;
  so.max_num_iterations = options.max_iterations;
  so.num_threads = 1;
  so.function_tolerance = 1e-12;
  so.gradient_tolerance = 1e-14;
  so.parameter_tolerance = 1e-12;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary cs;
  ceres::Solve(so, &problem, &cs);
  for (int v = 0; v < nv; ++v) {
    const Eigen::Vector3d w(aa[v][0], aa[v][1], aa[v][2]);
    const double angle = w.norm();
    const Eigen::Quaterniond q = angle > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(angle, w / angle))
                                           : Eigen::Quaterniond::Identity();
    r.world_from_sensor[v] = Rigid3d(q, Eigen::Vector3d(t[v][0], t[v][1], t[v][2]));
  }
  for (int k = 0; k < nm; ++k) r.markers_in_world[k] = Eigen::Vector3d(X[k][0], X[k][1], X[k][2]);
  Residuals(r.world_from_sensor, r.markers_in_world, sightings, &s.rms_final_mm, &s.max_final_mm);
  s.iterations = static_cast<int>(cs.iterations.size());
  s.status = cs.termination_type == ceres::CONVERGENCE ? AdjustmentStatus::kOk
                                                       : AdjustmentStatus::kNotConverged;
  if (!s.ok()) s.message = cs.message;
  s.seconds = timer.ElapsedSeconds();
  return r;
}

}  // namespace fringe::registration
