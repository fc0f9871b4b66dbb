#include "fringe/calib/refine_rig.h"

#include <ceres/cubic_interpolation.h>
#include <ceres/sphere_manifold.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/QR>
#include <cmath>
#include <memory>

#include "fringe/util/error.h"
#include "fringe/util/format.h"

namespace fringe::calib {
namespace {

using util::FigureOrNull;
using util::Fixed;
using util::StrCat;
using Interpolator = ceres::BiCubicInterpolator<ceres::Grid2D<float, 1>>;

constexpr double kDeg = 180 / M_PI;
constexpr double kSqrt2 = 1.4142135623730951;

template <typename T>
void RotateTranslate(const T* rotation, const T* translation, const T* p, T* out) {
  ceres::AngleAxisRotatePoint(rotation, p, out);
  for (int i = 0; i < 3; ++i) out[i] += translation[i];
}

// A point's pixel in the left camera (the sensor frame): (projection - observed) / sigma.
struct LeftPixelCost {
  Eigen::Vector2d observed_px;
  double sigma;
  template <typename T>
  bool operator()(const T* intrinsics, const T* p_in_left, T* r) const {
    if (!ReprojectionResidual(intrinsics, p_in_left, observed_px, r)) return false;
    r[0] /= T(sigma);
    r[1] /= T(sigma);
    return true;
  }
};

// A point's pixel in the right camera.
struct RightPixelCost {
  Eigen::Vector2d observed_px;
  double sigma;
  template <typename T>
  bool operator()(const T* intrinsics, const T* rotation, const T* translation, const T* p_in_left,
                  T* r) const {
    T p[3];
    RotateTranslate(rotation, translation, p_in_left, p);
    if (!ReprojectionResidual(intrinsics, p, observed_px, r)) return false;
    r[0] /= T(sigma);
    r[1] /= T(sigma);
    return true;
  }
};

// The right camera's phase at the point's projection minus the left phase.
struct RightPhaseCost {
  const Interpolator* phase;
  double left_phase, sigma;
  template <typename T>
  bool operator()(const T* intrinsics, const T* rotation, const T* translation, const T* p_in_left,
                  T* r) const {
    T p[3], px[2];
    RotateTranslate(rotation, translation, p_in_left, p);
    if (!ProjectWithIntrinsics(intrinsics, p, px)) return false;
    T value;
    phase->Evaluate(px[1], px[0], &value);
    // Points are chosen where the right phase is valid around their start; a step that moves a
    // projection into undecoded pixels (NaN) must not end the solve (Ceres stops at the first
    // non-finite residual): there the point has no right-phase evidence.
    if (!ceres::isfinite(value)) {
      r[0] = T(0);
      return true;
    }
    r[0] = (value - T(left_phase)) / T(sigma);
    return true;
  }
};

// The projector column of the point minus the left phase; the projector's intrinsics are data.
// Its orientation is R_y(yaw) R(rotation): the yaw block (about the projector's own y axis) is
// free only with a sphere constraint (header).
struct ProjectorColumnCost {
  IntrinsicsBlock projector;
  double left_phase, sigma;
  template <typename T>
  bool operator()(const T* rotation, const T* yaw, const T* translation, const T* p_in_left,
                  T* r) const {
    T q[3], p[3], px[2], k[kNumIntrinsics];
    for (int i = 0; i < kNumIntrinsics; ++i) k[i] = T(projector[static_cast<size_t>(i)]);
    ceres::AngleAxisRotatePoint(rotation, p_in_left, q);
    const T c = cos(yaw[0]), s = sin(yaw[0]);
    p[0] = c * q[0] + s * q[2] + translation[0];
    p[1] = q[1] + translation[1];
    p[2] = -s * q[0] + c * q[2] + translation[2];
    if (!ProjectWithIntrinsics(k, p, px)) return false;
    r[0] = (px[0] - T(left_phase)) / T(sigma);
    return true;
  }
};

// A point's distance from its sphere's centre minus the radius.
struct SphereCost {
  double sigma;
  template <typename T>
  bool operator()(const T* p_in_left, const T* centre, const T* radius, T* r) const {
    const T d[3] = {p_in_left[0] - centre[0], p_in_left[1] - centre[1], p_in_left[2] - centre[2]};
    r[0] = (sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) - radius[0]) / T(sigma);
    return true;
  }
};

Eigen::Vector3d RotationVector(const Rigid3d& t) {
  const Eigen::AngleAxisd aa(t.rotation());
  return aa.axis() * aa.angle();
}

Rigid3d FromBlocks(const double* w, const double* t) {
  const Eigen::Vector3d v(w[0], w[1], w[2]);
  const double angle = v.norm();
  const Eigen::Vector3d tt(t[0], t[1], t[2]);
  if (angle < 1e-300) return Rigid3d(Eigen::Quaterniond::Identity(), tt);
  return Rigid3d::FromAxisAngle(v / angle, angle, tt);
}

Rigid3d ProjectorFromBlocks(const double* w, double yaw, const double* t) {
  const Rigid3d rotated = FromBlocks(w, t);
  const Eigen::Quaterniond q(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()));
  return Rigid3d(q * rotated.rotation(), rotated.translation());
}

// RMS of a group of residual blocks (in their own unit: residual * sigma), NaN when empty.
double GroupRms(ceres::Problem* problem, const std::vector<ceres::ResidualBlockId>& ids,
                double sigma) {
  if (ids.empty()) return std::numeric_limits<double>::quiet_NaN();
  ceres::Problem::EvaluateOptions eo;
  eo.residual_blocks = ids;
  eo.apply_loss_function = false;
  std::vector<double> r;
  if (!problem->Evaluate(eo, nullptr, &r, nullptr, nullptr) || r.empty()) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  double sum2 = 0;
  for (double v : r) sum2 += v * v;
  return sigma * std::sqrt(sum2 / static_cast<double>(r.size()));
}

double MarkerEpipolarRms(const StereoRig& rig, const std::vector<RefineMarker>& markers) {
  if (markers.empty()) return std::numeric_limits<double>::quiet_NaN();
  double sum2 = 0;
  for (const RefineMarker& m : markers) {
    const double d = SignedEpipolarDistancePx(rig, m.left_px, m.right_px);
    sum2 += d * d;
  }
  return std::sqrt(sum2 / static_cast<double>(markers.size()));
}

// Standard deviations of the rig blocks (ambient coordinates; 0 for constant blocks and
// coordinates a manifold holds) with the points (3 each, every residual block touches exactly
// one) eliminated by their Schur complement: S = J_c'J_c - sum_i B_i' A_i^-1 B_i over the
// robustified Jacobian, covariance sigma^2 S^-1 with sigma^2 = 2 cost / (residuals - free
// parameters), the fit's own residual variance (the noise options set the weights between
// kinds, the data their scale). A direction of S the data do not determine (eigenvalue below
// 1e-10 of the largest) gives an infinite sigma to every parameter it moves, rather than being
// dropped as a pseudo-inverse would. Dense in the rig's few parameters, linear in the points: a
// scan's tens of thousands of points stay cheap. Returns false when nothing is redundant.
bool RigStandardDeviations(ceres::Problem* problem, const std::vector<const double*>& rig_blocks,
                           const std::vector<double*>& point_blocks,
                           std::vector<std::vector<double>>* sd) {
  sd->assign(rig_blocks.size(), {});
  for (size_t i = 0; i < rig_blocks.size(); ++i) {
    (*sd)[i].assign(static_cast<size_t>(problem->ParameterBlockSize(rig_blocks[i])), 0.0);
  }
  std::vector<double*> free_rig;
  std::vector<int> rig_offset;  // tangent offset of each free rig block
  int nc = 0;
  for (const double* b : rig_blocks) {
    double* m = const_cast<double*>(b);
    rig_offset.push_back(nc);
    if (problem->IsParameterBlockConstant(m)) continue;
    free_rig.push_back(m);
    nc += problem->ParameterBlockTangentSize(m);
  }
  ceres::Problem::EvaluateOptions eo;
  eo.parameter_blocks = free_rig;
  for (double* p : point_blocks) eo.parameter_blocks.push_back(p);
  eo.apply_loss_function = true;
  double cost = 0;
  ceres::CRSMatrix jac;
  if (!problem->Evaluate(eo, &cost, nullptr, nullptr, &jac)) return false;
  const int m = jac.num_rows;
  const int n = nc + 3 * static_cast<int>(point_blocks.size());
  if (m <= n || nc == 0) return false;
  const double sigma2 = 2 * cost / (m - n);
  Eigen::MatrixXd ncc = Eigen::MatrixXd::Zero(nc, nc);
  std::vector<Eigen::Matrix3d> a(point_blocks.size(), Eigen::Matrix3d::Zero());
  std::vector<Eigen::MatrixXd> b(point_blocks.size(), Eigen::MatrixXd::Zero(3, nc));
  Eigen::VectorXd jc(nc);
  for (int r = 0; r < m; ++r) {
    jc.setZero();
    Eigen::Vector3d jp = Eigen::Vector3d::Zero();
    int point = -1;
    for (int k = jac.rows[static_cast<size_t>(r)]; k < jac.rows[static_cast<size_t>(r) + 1]; ++k) {
      const int c = jac.cols[static_cast<size_t>(k)];
      const double v = jac.values[static_cast<size_t>(k)];
      if (c < nc) {
        jc[c] = v;
      } else {
        point = (c - nc) / 3;
        jp[(c - nc) % 3] = v;
      }
    }
    ncc.noalias() += jc * jc.transpose();
    if (point >= 0) {
      a[static_cast<size_t>(point)].noalias() += jp * jp.transpose();
      b[static_cast<size_t>(point)].noalias() += jp * jc.transpose();
    }
  }
  for (size_t i = 0; i < point_blocks.size(); ++i) {
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(a[i]);
    if (ldlt.info() != Eigen::Success || !(a[i].norm() > 0)) continue;  // a point nothing sees
    ncc.noalias() -= b[i].transpose() * ldlt.solve(b[i]);
  }
  // Scale the columns so that the eigenvalue test compares like with like (degrees, mm, px).
  Eigen::VectorXd scale = ncc.diagonal().cwiseMax(0).cwiseSqrt();
  for (int k = 0; k < nc; ++k) scale[k] = scale[k] > 0 ? 1 / scale[k] : 0;
  const Eigen::MatrixXd scaled = scale.asDiagonal() * ncc * scale.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(scaled);
  if (eig.info() != Eigen::Success) return false;
  const Eigen::VectorXd& lambda = eig.eigenvalues();
  const double lambda_max = lambda.maxCoeff();
  Eigen::MatrixXd inverse = Eigen::MatrixXd::Zero(nc, nc);
  Eigen::VectorXd undetermined = Eigen::VectorXd::Zero(nc);  // weight in null directions
  for (int k = 0; k < nc; ++k) {
    const Eigen::VectorXd v = eig.eigenvectors().col(k);
    if (lambda[k] > 1e-10 * lambda_max) {
      inverse.noalias() += v * v.transpose() / lambda[k];
    } else {
      undetermined += v.cwiseAbs2();
    }
  }
  const Eigen::MatrixXd cov = sigma2 * scale.asDiagonal() * inverse * scale.asDiagonal();
  // Per block: ambient covariance through the manifold's plus Jacobian.
  for (size_t i = 0; i < rig_blocks.size(); ++i) {
    double* blk = const_cast<double*>(rig_blocks[i]);
    if (problem->IsParameterBlockConstant(blk)) continue;
    const int size = problem->ParameterBlockSize(blk);
    const int tangent = problem->ParameterBlockTangentSize(blk);
    const int off = rig_offset[i];
    Eigen::MatrixXd plus = Eigen::MatrixXd::Identity(size, tangent);
    if (const ceres::Manifold* man = problem->GetManifold(blk)) {
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> pj(size, tangent);
      man->PlusJacobian(blk, pj.data());
      plus = pj;
    }
    const Eigen::MatrixXd c = plus * cov.block(off, off, tangent, tangent) * plus.transpose();
    const Eigen::VectorXd null_weight = plus.cwiseAbs() * undetermined.segment(off, tangent);
    for (int k = 0; k < size; ++k) {
      (*sd)[i][static_cast<size_t>(k)] = null_weight[k] > 1e-6
                                             ? std::numeric_limits<double>::infinity()
                                             : std::sqrt(std::max(0.0, c(k, k)));
    }
  }
  return true;
}

// The rig as the bundle's blocks hold it (values, not the problem's blocks).
struct RigValues {
  IntrinsicsBlock left, right, projector;
  Eigen::Vector3d right_w, right_t, proj_w, proj_t;
  double proj_yaw = 0;
  bool has_projector = false;
};

// Points triangulated again under `rig` from their own observations alone (left pixel, right
// phase, projector column; no sphere residual), each its own small problem started at
// `start`: what a rig measures, for the sphere's shape figures. A point that does not converge
// is left out (its index is not in *kept).
std::vector<Eigen::Vector3d> Retriangulate(const RigRefinementData& data,
                                           const std::vector<size_t>& which,
                                           const std::vector<std::unique_ptr<Interpolator>>& phase,
                                           const RigValues& rig, const RigRefinementOptions& o,
                                           std::vector<size_t>* kept) {
  RigValues v = rig;  // Ceres takes non-const blocks; they are constant here
  std::vector<Eigen::Vector3d> out;
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  so.max_num_iterations = 50;
  for (size_t i : which) {
    const RefinePhasePoint& pt = data.points[i];
    Eigen::Vector3d p = pt.p_in_left;
    ceres::Problem problem;
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<LeftPixelCost, 2, kNumIntrinsics, 3>(
                                 new LeftPixelCost{pt.left_px, o.pixel_sigma_px}),
                             nullptr, v.left.data(), p.data());
    problem.SetParameterBlockConstant(v.left.data());
    const size_t view = static_cast<size_t>(pt.view);
    if (view < phase.size() && phase[view]) {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<RightPhaseCost, 1, kNumIntrinsics, 3, 3, 3>(
              new RightPhaseCost{phase[view].get(), pt.phase, kSqrt2 * o.phase_sigma_px}),
          nullptr, v.right.data(), v.right_w.data(), v.right_t.data(), p.data());
      for (double* b : {v.right.data(), v.right_w.data(), v.right_t.data()}) {
        problem.SetParameterBlockConstant(b);
      }
    }
    if (v.has_projector) {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<ProjectorColumnCost, 1, 3, 1, 3, 3>(
              new ProjectorColumnCost{v.projector, pt.phase, o.phase_sigma_px}),
          nullptr, v.proj_w.data(), &v.proj_yaw, v.proj_t.data(), p.data());
      for (double* b : {v.proj_w.data(), &v.proj_yaw, v.proj_t.data()}) {
        problem.SetParameterBlockConstant(b);
      }
    }
    if (problem.NumResiduals() < 3) continue;  // two pixel coordinates alone fix no depth
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    // A point its own observations contradict (a phase interpolated across an occlusion edge:
    // the bundle's Huber loss bounds it there) would distort the shape fit: left out.
    const double rms_sigmas =
        std::sqrt(2 * summary.final_cost / static_cast<double>(problem.NumResiduals()));
    if (summary.termination_type == ceres::CONVERGENCE && p.allFinite() &&
        rms_sigmas <= o.loss_sigmas) {
      out.push_back(p);
      kept->push_back(i);
    }
  }
  return out;
}

// Mean spheroid semi-axes across and along the viewing direction (from the left camera's
// centre to each sphere's centre) over the spheres, weighted by their points; false when no
// sphere has a spheroid fit.
bool SphereShape(const std::vector<Eigen::Vector3d>& points, const std::vector<int>& sphere_of,
                 const std::vector<Eigen::Vector3d>& centres, double* across_mm, double* along_mm) {
  double across = 0, along = 0, weight = 0;
  for (size_t k = 0; k < centres.size(); ++k) {
    std::vector<Eigen::Vector3d> on;
    for (size_t i = 0; i < points.size(); ++i) {
      if (sphere_of[i] == static_cast<int>(k)) on.push_back(points[i]);
    }
    const SpheroidFit fit = FitSpheroid(on, centres[k].normalized());
    if (!fit.ok) continue;
    const double w = static_cast<double>(on.size());
    across += w * fit.across_mm;
    along += w * fit.along_mm;
    weight += w;
  }
  if (!(weight > 0)) return false;
  *across_mm = across / weight;
  *along_mm = along / weight;
  return true;
}

}  // namespace

const char* ToString(RefineScale s) {
  switch (s) {
    case RefineScale::kAuto:
      return "auto";
    case RefineScale::kBaseline:
      return "baseline";
    case RefineScale::kProjector:
      return "projector";
    case RefineScale::kArtefact:
      return "artefact";
  }
  return "?";
}

SpheroidFit FitSpheroid(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& axis) {
  SpheroidFit fit;
  if (points.size() < 6 || !(axis.norm() > 0)) return fit;
  // Frame: z along the axis; centred on the points' mean for conditioning.
  const Eigen::Quaterniond to_frame =
      Eigen::Quaterniond::FromTwoVectors(axis.normalized(), Eigen::Vector3d::UnitZ());
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) mean += p;
  mean /= static_cast<double>(points.size());
  Eigen::MatrixXd a(static_cast<Eigen::Index>(points.size()), 5);
  const Eigen::VectorXd b = Eigen::VectorXd::Ones(static_cast<Eigen::Index>(points.size()));
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d q = to_frame * (points[i] - mean);
    a.row(static_cast<Eigen::Index>(i)) << q.x() * q.x() + q.y() * q.y(), q.z() * q.z(), q.x(),
        q.y(), q.z();
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(a);
  if (qr.rank() < 5) return fit;
  const Eigen::VectorXd x = qr.solve(b);
  const double ac = x[0], cc = x[1];
  if (!(ac > 0) || !(cc > 0)) return fit;
  const Eigen::Vector3d c0(-x[2] / (2 * ac), -x[3] / (2 * ac), -x[4] / (2 * cc));
  const double k = 1 + ac * (c0.x() * c0.x() + c0.y() * c0.y()) + cc * c0.z() * c0.z();
  if (!(k > 0)) return fit;
  fit.across_mm = std::sqrt(k / ac);
  fit.along_mm = std::sqrt(k / cc);
  fit.centre = mean + to_frame.inverse() * c0;
  fit.ok = std::isfinite(fit.across_mm) && std::isfinite(fit.along_mm);
  return fit;
}

const char* ToString(RefineStatus s) {
  switch (s) {
    case RefineStatus::kOk:
      return "ok";
    case RefineStatus::kNoEvidence:
      return "no evidence";
    case RefineStatus::kNotDetermined:
      return "not determined";
    case RefineStatus::kFailed:
      return "failed";
    case RefineStatus::kNotSignificant:
      return "not significant";
  }
  return "?";
}

void RigRefinementOptions::Check() const {
  using util::CheckOption;
  const char* o = "RigRefinementOptions";
  CheckOption(pixel_sigma_px > 0, o, "pixel_sigma_px", pixel_sigma_px, "must be > 0");
  CheckOption(phase_sigma_px > 0, o, "phase_sigma_px", phase_sigma_px, "must be > 0");
  CheckOption(marker_sigma_px > 0, o, "marker_sigma_px", marker_sigma_px, "must be > 0");
  CheckOption(loss_sigmas > 0, o, "loss_sigmas", loss_sigmas, "must be > 0");
  CheckOption(max_rotation_sigma_deg > 0, o, "max_rotation_sigma_deg", max_rotation_sigma_deg,
              "must be > 0");
  CheckOption(max_translation_sigma_mm > 0, o, "max_translation_sigma_mm", max_translation_sigma_mm,
              "must be > 0");
  CheckOption(min_change_sigmas > 0, o, "min_change_sigmas", min_change_sigmas, "must be > 0");
  CheckOption(min_evidence_ratio > 0 && min_evidence_ratio <= 1, o, "min_evidence_ratio",
              min_evidence_ratio, "must be in (0, 1]");
  CheckOption(settle_sigmas > 0, o, "settle_sigmas", settle_sigmas, "must be > 0");
  CheckOption(max_rounds >= 1, o, "max_rounds", max_rounds, "must be >= 1");
  CheckOption(max_focal_sigma_fraction > 0, o, "max_focal_sigma_fraction", max_focal_sigma_fraction,
              "must be > 0");
  if (sphere) {
    CheckOption(sphere->diameter_mm > 0 && std::isfinite(sphere->diameter_mm), o,
                "sphere.diameter_mm", sphere->diameter_mm, "must be > 0");
    CheckOption(sphere->sigma_mm > 0 && std::isfinite(sphere->sigma_mm), o, "sphere.sigma_mm",
                sphere->sigma_mm, "must be > 0");
  }
  solve.Check();
}

std::string RigRefinementSummary::BriefReport() const {
  std::string s = StrCat("refine: ", ToString(status), " (", views, " views, ", points,
                         " phase points, ", markers, " markers)");
  if (status == RefineStatus::kOk) {
    s += StrCat("; right camera turned by ", Fixed(right_rotation_change_deg, 4), " deg, baseline ",
                Fixed(baseline_before_mm, 3), " -> ", Fixed(baseline_after_mm, 3), " mm");
    if (std::isfinite(marker_epipolar_rms_before_px)) {
      s += StrCat("; markers' epipolar RMS ", Fixed(marker_epipolar_rms_before_px, 3), " -> ",
                  Fixed(marker_epipolar_rms_after_px, 3), " px");
    }
    if (std::isfinite(projector_rms_before_px)) {
      s += StrCat("; projector column RMS ", Fixed(projector_rms_before_px, 3), " -> ",
                  Fixed(projector_rms_after_px, 3), " px");
    }
  }
  if (spheres > 0 || sphere_points > 0) {
    s += StrCat("; sphere: ", sphere_points, " points in ", spheres,
                " views, axis ratio along the view ", Fixed(sphere_axis_ratio_before, 4), " -> ",
                Fixed(sphere_axis_ratio_after, 4), ", radius across ",
                Fixed(sphere_radius_across_before_mm, 3), " -> ",
                Fixed(sphere_radius_across_after_mm, 3), " mm");
  }
  if (!message.empty()) s += ": " + message;
  return s;
}

nlohmann::json ToJson(const RigRefinementSummary& s) {
  nlohmann::json params = nlohmann::json::array();
  for (const RefinedParameter& p : s.parameters) {
    params.push_back({{"name", p.name},
                      {"unit", p.unit},
                      {"before", p.before},
                      {"after", p.after},
                      {"change", p.after - p.before},
                      {"sigma", p.sigma}});
  }
  return {{"status", ToString(s.status)},
          {"message", s.message},
          {"scale", ToString(s.scale)},
          {"refined", s.refined},
          {"parameters", params},
          {"views", s.views},
          {"points", s.points},
          {"markers", s.markers},
          {"marker_epipolar_rms_before_px", FigureOrNull(s.marker_epipolar_rms_before_px)},
          {"marker_epipolar_rms_after_px", FigureOrNull(s.marker_epipolar_rms_after_px)},
          {"right_phase_rms_before_px", FigureOrNull(s.right_phase_rms_before_px)},
          {"right_phase_rms_after_px", FigureOrNull(s.right_phase_rms_after_px)},
          {"projector_rms_before_px", FigureOrNull(s.projector_rms_before_px)},
          {"projector_rms_after_px", FigureOrNull(s.projector_rms_after_px)},
          {"right_rotation_change_deg", s.right_rotation_change_deg},
          {"projector_rotation_change_deg", s.projector_rotation_change_deg},
          {"baseline_before_mm", s.baseline_before_mm},
          {"baseline_after_mm", s.baseline_after_mm},
          {"spheres", s.spheres},
          {"sphere_points", s.sphere_points},
          {"sphere_rms_before_mm", FigureOrNull(s.sphere_rms_before_mm)},
          {"sphere_rms_after_mm", FigureOrNull(s.sphere_rms_after_mm)},
          {"sphere_axis_ratio_before", FigureOrNull(s.sphere_axis_ratio_before)},
          {"sphere_axis_ratio_after", FigureOrNull(s.sphere_axis_ratio_after)},
          {"sphere_radius_across_before_mm", FigureOrNull(s.sphere_radius_across_before_mm)},
          {"sphere_radius_across_after_mm", FigureOrNull(s.sphere_radius_across_after_mm)},
          {"sphere_radius_along_before_mm", FigureOrNull(s.sphere_radius_along_before_mm)},
          {"sphere_radius_along_after_mm", FigureOrNull(s.sphere_radius_along_after_mm)},
          {"solve_rounds", s.solve_rounds},
          {"solver", s.solve.BriefReport()}};
}

RigRefinement RefineRig(const StereoRig& rig, const RigRefinementData& data,
                        const RigRefinementOptions& options) {
  options.Check();
  rig.Check();
  if (options.scale == RefineScale::kProjector && !rig.projector) {
    throw Error("refine: the scale is to be held by the projector, but the rig has none");
  }
  if (options.scale == RefineScale::kArtefact && !options.sphere) {
    throw Error("refine: the scale is to be held by the artefact, but no sphere is given");
  }
  RefineScale scale = options.scale;
  if (scale == RefineScale::kAuto) {
    scale = options.sphere  ? RefineScale::kArtefact
            : rig.projector ? RefineScale::kProjector
                            : RefineScale::kBaseline;
  }
  std::vector<int> sphere_count(data.spheres.size(), 0);
  for (const RefinePhasePoint& p : data.points) {
    if (p.sphere < 0) continue;
    if (static_cast<size_t>(p.sphere) >= data.spheres.size() ||
        data.spheres[static_cast<size_t>(p.sphere)].view != p.view) {
      throw Error(StrCat("refine: a phase point of view ", p.view, " names sphere ", p.sphere,
                         ", which the data do not have in that view"));
    }
    ++sphere_count[static_cast<size_t>(p.sphere)];
  }
  RigRefinement out;
  out.rig = rig;
  RigRefinementSummary& s = out.summary;
  s.scale = scale;
  s.points = static_cast<int>(data.points.size());
  s.markers = static_cast<int>(data.markers.size());
  {
    int views = 0;
    for (const auto& p : data.points) views = std::max(views, p.view + 1);
    for (const auto& m : data.markers) views = std::max(views, m.view + 1);
    s.views = views;
  }
  s.baseline_before_mm = s.baseline_after_mm = rig.BaselineMm();
  s.marker_epipolar_rms_before_px = s.marker_epipolar_rms_after_px =
      MarkerEpipolarRms(rig, data.markers);
  const bool use_projector = rig.projector.has_value() && !data.points.empty();
  // The sphere constraint: the points on a sphere (none without options.sphere).
  std::vector<size_t> on_sphere;
  if (options.sphere) {
    for (size_t i = 0; i < data.points.size(); ++i) {
      if (data.points[i].sphere >= 0) on_sphere.push_back(i);
    }
    for (int n : sphere_count) s.spheres += n > 0 ? 1 : 0;
    s.sphere_points = static_cast<int>(on_sphere.size());
    // A sphere constrains its size with 4 unknowns (centre, radius); fewer points say nothing.
    constexpr int kMinSpherePoints = 20;
    if (s.sphere_points < kMinSpherePoints) {
      s.status = RefineStatus::kNoEvidence;
      s.message = StrCat("the certified sphere (diameter ", options.sphere->diameter_mm,
                         " mm) was asked for, but ", s.sphere_points,
                         " phase points lie on a sphere (at least ", kMinSpherePoints,
                         " needed): no sphere was found in the data; the rig is unchanged");
      return out;
    }
  }
  // Enough for the five or six unknowns of a camera pose, with room to spare.
  constexpr int kMinMarkers = 8;
  if (!use_projector && on_sphere.empty() && static_cast<int>(data.markers.size()) < kMinMarkers) {
    s.status = RefineStatus::kNoEvidence;
    s.message = StrCat(
        "nothing constrains the rig: ", data.markers.size(),
        " markers seen by both cameras (at least ", kMinMarkers,
        " needed) and no calibrated projector; with vertical fringes alone a stereo point is "
        "not redundant (its right phase fixes its depth, nothing more); the rig is unchanged");
    return out;
  }

  // Blocks.
  IntrinsicsBlock left = IntrinsicsBlockOf(rig.left), right = IntrinsicsBlockOf(rig.right);
  Eigen::Vector3d right_w = RotationVector(rig.right_from_left);
  Eigen::Vector3d right_t = rig.right_from_left.translation();
  Eigen::Vector3d proj_w = Eigen::Vector3d::Zero(), proj_t = Eigen::Vector3d::Zero();
  IntrinsicsBlock projector{};
  if (rig.projector) {
    projector = IntrinsicsBlockOf(*rig.projector);
    proj_w = RotationVector(rig.projector_from_left);
    proj_t = rig.projector_from_left.translation();
  }
  double proj_yaw = 0;  // about the projector's y axis, on top of proj_w (ProjectorColumnCost)
  // Per sphere: its centre (3) and radius (1; held at the certified one under kArtefact).
  std::vector<Eigen::Vector3d> centres(data.spheres.size());
  std::vector<double> radii(data.spheres.size(),
                            options.sphere ? 0.5 * options.sphere->diameter_mm : 0);
  for (size_t k = 0; k < centres.size(); ++k) centres[k] = data.spheres[k].centre_in_left;
  std::vector<Eigen::Vector3d> points(data.points.size()), markers(data.markers.size());
  for (size_t i = 0; i < points.size(); ++i) points[i] = data.points[i].p_in_left;
  for (size_t i = 0; i < markers.size(); ++i) markers[i] = data.markers[i].p_in_left;

  // The right phase maps as Ceres grids (rows x cols, one channel).
  std::vector<std::unique_ptr<ceres::Grid2D<float, 1>>> grids(data.right_phase.size());
  std::vector<std::unique_ptr<Interpolator>> phase(data.right_phase.size());
  for (size_t v = 0; v < data.right_phase.size(); ++v) {
    const cv::Mat& m = data.right_phase[v];
    if (m.empty()) continue;
    if (m.type() != CV_32F || !m.isContinuous()) {
      throw Error(StrCat("refine: view ", v, ": the right phase map must be continuous CV_32F"));
    }
    grids[v] = std::make_unique<ceres::Grid2D<float, 1>>(m.ptr<float>(), 0, m.rows, 0, m.cols);
    phase[v] = std::make_unique<Interpolator>(*grids[v]);
  }

  ceres::Problem problem;
  const double phase_loss = options.loss_sigmas;  // residuals are in sigmas
  std::vector<ceres::ResidualBlockId> right_phase_ids, projector_ids;
  for (size_t i = 0; i < data.points.size(); ++i) {
    const RefinePhasePoint& p = data.points[i];
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<LeftPixelCost, 2, kNumIntrinsics, 3>(
                                 new LeftPixelCost{p.left_px, options.pixel_sigma_px}),
                             NewLossFunction(RobustLoss::kHuber, phase_loss), left.data(),
                             points[i].data());
    const size_t v = static_cast<size_t>(p.view);
    if (v < phase.size() && phase[v]) {
      right_phase_ids.push_back(problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<RightPhaseCost, 1, kNumIntrinsics, 3, 3, 3>(
              new RightPhaseCost{phase[v].get(), p.phase, kSqrt2 * options.phase_sigma_px}),
          NewLossFunction(RobustLoss::kHuber, phase_loss), right.data(), right_w.data(),
          right_t.data(), points[i].data()));
    }
    if (use_projector) {
      projector_ids.push_back(problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<ProjectorColumnCost, 1, 3, 1, 3, 3>(
              new ProjectorColumnCost{projector, p.phase, options.phase_sigma_px}),
          NewLossFunction(RobustLoss::kHuber, phase_loss), proj_w.data(), &proj_yaw, proj_t.data(),
          points[i].data()));
    }
  }
  std::vector<ceres::ResidualBlockId> sphere_ids;
  for (size_t i : on_sphere) {
    const size_t k = static_cast<size_t>(data.points[i].sphere);
    sphere_ids.push_back(
        problem.AddResidualBlock(new ceres::AutoDiffCostFunction<SphereCost, 1, 3, 3, 1>(
                                     new SphereCost{options.sphere->sigma_mm}),
                                 NewLossFunction(RobustLoss::kHuber, phase_loss), points[i].data(),
                                 centres[k].data(), &radii[k]));
  }
  for (size_t i = 0; i < data.markers.size(); ++i) {
    const RefineMarker& m = data.markers[i];
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<LeftPixelCost, 2, kNumIntrinsics, 3>(
                                 new LeftPixelCost{m.left_px, options.marker_sigma_px}),
                             NewLossFunction(RobustLoss::kHuber, phase_loss), left.data(),
                             markers[i].data());
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<RightPixelCost, 2, kNumIntrinsics, 3, 3, 3>(
            new RightPixelCost{m.right_px, options.marker_sigma_px}),
        NewLossFunction(RobustLoss::kHuber, phase_loss), right.data(), right_w.data(),
        right_t.data(), markers[i].data());
  }
  const bool has_right = problem.HasParameterBlock(right_w.data());
  // What is free: intrinsics (fx fy k1 k2) on request; the right pose; the projector's
  // pose unless it holds the scale. The scale: a translation's length held.
  // The principal points stay: a shift of cx moves every point of a camera sideways, which is
  // what a yaw does (cy: a pitch), so with the rotations free they are not determined.
  const FreeIntrinsics free_intrinsics = {true, true,  false, false, true,
                                          true, false, false, false};
  for (double* k : {left.data(), right.data()}) {
    if (!problem.HasParameterBlock(k)) continue;
    if (options.intrinsics) {
      problem.SetManifold(k, NewIntrinsicsManifold(free_intrinsics));
    } else {
      problem.SetParameterBlockConstant(k);
    }
  }
  if (options.intrinsics) s.refined.push_back("focal lengths and k1 k2 of both cameras");
  if (has_right) {
    s.refined.push_back("right_from_left rotation");
    if (scale == RefineScale::kArtefact) {
      s.refined.push_back("right_from_left translation (the sphere's diameter holds the scale)");
    } else if (scale == RefineScale::kBaseline) {
      problem.SetManifold(right_t.data(), new ceres::SphereManifold<3>());
      s.refined.push_back(
          "right_from_left translation direction (its length, the baseline, "
          "holds the scale)");
    } else {
      s.refined.push_back("right_from_left translation (the projector holds the scale)");
    }
  }
  if (use_projector) {
    // Its pitch and roll stay; its yaw holds the depth gauge unless a sphere does (header).
    problem.SetParameterBlockConstant(proj_w.data());
    if (on_sphere.empty()) {
      problem.SetParameterBlockConstant(&proj_yaw);
    } else {
      s.refined.push_back("projector yaw (the sphere's shape holds the depth gauge)");
    }
    if (scale == RefineScale::kProjector) {
      problem.SetParameterBlockConstant(proj_t.data());
    } else {
      // Its shift along its own columns (projector y) is invisible to vertical fringes.
      problem.SetManifold(proj_t.data(), new ceres::SubsetManifold(3, {1}));
      s.refined.push_back("projector_from_left translation (x, z)");
    }
  }

  for (size_t k = 0; k < radii.size(); ++k) {
    if (!problem.HasParameterBlock(&radii[k])) continue;
    if (scale == RefineScale::kArtefact) problem.SetParameterBlockConstant(&radii[k]);
  }
  if (!on_sphere.empty()) {
    s.refined.push_back(scale == RefineScale::kArtefact
                            ? "the sphere's centre per view (its certified radius held)"
                            : "the sphere's centre and radius per view (shape only)");
  }
  const IntrinsicsBlock left0 = left, right0 = right;
  const Eigen::Vector3d right_w0 = right_w, right_t0 = right_t, proj_w0 = proj_w, proj_t0 = proj_t;
  // Before: the points as the initial rig triangulated them.
  s.right_phase_rms_before_px = GroupRms(&problem, right_phase_ids, options.phase_sigma_px);
  s.projector_rms_before_px = GroupRms(&problem, projector_ids, options.phase_sigma_px);
  if (!on_sphere.empty()) {
    // The free radius starts where the initial points put it: their mean distance from the centre.
    if (scale != RefineScale::kArtefact) {
      std::vector<double> sum(radii.size(), 0.0);
      for (size_t i : on_sphere) {
        const size_t k = static_cast<size_t>(data.points[i].sphere);
        sum[k] += (points[i] - centres[k]).norm();
      }
      for (size_t k = 0; k < radii.size(); ++k) {
        if (sphere_count[k] > 0) radii[k] = sum[k] / sphere_count[k];
      }
    }
    s.sphere_rms_before_mm = GroupRms(&problem, sphere_ids, options.sphere->sigma_mm);
  }
  std::vector<int> sphere_of;
  std::vector<Eigen::Vector3d> sphere_points0;
  for (size_t i : on_sphere) {
    sphere_of.push_back(data.points[i].sphere);
    sphere_points0.push_back(data.points[i].p_in_left);
  }
  if (!on_sphere.empty() &&
      SphereShape(sphere_points0, sphere_of, centres, &s.sphere_radius_across_before_mm,
                  &s.sphere_radius_along_before_mm)) {
    s.sphere_axis_ratio_before = s.sphere_radius_along_before_mm / s.sphere_radius_across_before_mm;
  }
  s.sphere_axis_ratio_after = s.sphere_axis_ratio_before;
  s.sphere_radius_across_after_mm = s.sphere_radius_across_before_mm;
  s.sphere_radius_along_after_mm = s.sphere_radius_along_before_mm;
  s.sphere_rms_after_mm = s.sphere_rms_before_mm;
  s.solve = Solve(options.solve, &problem);
  const auto restore = [&] {
    left = left0;
    right = right0;
    right_w = right_w0;
    right_t = right_t0;
    proj_w = proj_w0;
    proj_t = proj_t0;
    proj_yaw = 0;
  };
  // A solve that ran out of iterations is often a problem the data do not determine (a flat
  // view with free focal lengths wanders along the undetermined direction): the uncertainty
  // check below says which; a numerical failure is reported as such.
  if (!s.solve.converged() && s.solve.termination != ceres::NO_CONVERGENCE) {
    s.status = RefineStatus::kFailed;
    s.message = "the solver failed: " + s.solve.BriefReport() + "; the rig is unchanged";
    restore();
    return out;
  }
  // Uncertainties, and whether the data determine what was refined.
  // The spheres' centres and radii with the rig: a sphere residual touches a point and them, so
  // they go with the dense part of the Schur complement (RigStandardDeviations).
  std::vector<const double*> blocks = {left.data(),   right.data(),  right_w.data(), right_t.data(),
                                       proj_w.data(), proj_t.data(), &proj_yaw};
  for (size_t k = 0; k < centres.size(); ++k) {
    blocks.push_back(centres[k].data());
    blocks.push_back(&radii[k]);
  }
  std::vector<const double*> present;
  for (const double* b : blocks) {
    if (problem.HasParameterBlock(const_cast<double*>(b))) present.push_back(b);
  }
  std::vector<double*> point_blocks;
  for (Eigen::Vector3d& p : points) point_blocks.push_back(p.data());
  for (Eigen::Vector3d& p : markers) point_blocks.push_back(p.data());
  std::vector<std::vector<double>> sd;
  bool have_sd = RigStandardDeviations(&problem, present, point_blocks, &sd);
  // Further rounds until one moves no free rig coordinate by more than settle_sigmas of its
  // sigma (header: Ceres' tolerance stops in the pitch / vertical-shift valley of one view).
  const auto snapshot = [&] {
    std::vector<double> v;
    for (const double* b : present) {
      const int n = problem.ParameterBlockSize(const_cast<double*>(b));
      v.insert(v.end(), b, b + n);
    }
    return v;
  };
  const auto largest_move_in_sigmas = [&](const std::vector<double>& a,
                                          const std::vector<double>& b) {
    double worst = 0;
    size_t k = 0;
    for (size_t i = 0; i < present.size(); ++i) {
      for (double sigma : sd[i]) {
        const double d = std::abs(a[k] - b[k]);
        ++k;
        if (sigma > 0 && std::isfinite(sigma)) worst = std::max(worst, d / sigma);
      }
    }
    return worst;
  };
  int rounds = 1;
  bool settled = options.max_rounds == 1;  // one round: nothing to compare it with
  while (have_sd && s.solve.converged()) {
    if (rounds >= options.max_rounds) break;
    const std::vector<double> before = snapshot();
    const SolveReport again = Solve(options.solve, &problem);
    ++rounds;
    s.solve.termination = again.termination;
    s.solve.message = again.message;
    s.solve.iterations += again.iterations;
    s.solve.final_cost = again.final_cost;
    if (!again.converged()) break;
    const double moved = largest_move_in_sigmas(before, snapshot());
    have_sd = RigStandardDeviations(&problem, present, point_blocks, &sd);
    if (moved < options.settle_sigmas) {
      settled = true;
      break;
    }
  }
  s.solve_rounds = rounds;
  if (!s.solve.converged() && s.solve.termination != ceres::NO_CONVERGENCE) {
    s.status = RefineStatus::kFailed;
    s.message = "the solver failed: " + s.solve.BriefReport() + "; the rig is unchanged";
    restore();
    return out;
  }
  s.right_phase_rms_after_px = GroupRms(&problem, right_phase_ids, options.phase_sigma_px);
  s.projector_rms_after_px = GroupRms(&problem, projector_ids, options.phase_sigma_px);
  if (!on_sphere.empty()) {
    s.sphere_rms_after_mm = GroupRms(&problem, sphere_ids, options.sphere->sigma_mm);
  }
  const auto sigma_of = [&](const double* block, int k) {
    for (size_t i = 0; i < present.size(); ++i) {
      if (present[i] == block) return sd[i][static_cast<size_t>(k)];
    }
    return 0.0;
  };
  std::vector<std::string> undetermined;
  double largest_change_sigmas = 0;
  std::string largest_change;
  const auto add = [&](const std::string& name, const std::string& unit, double before,
                       double after, double sigma, double limit) {
    s.parameters.push_back({name, unit, before, after, sigma});
    if (!(sigma <= limit)) undetermined.push_back(StrCat(name, " (sigma ", sigma, " ", unit, ")"));
    if (sigma > 0 && std::abs(after - before) / sigma > largest_change_sigmas) {
      largest_change_sigmas = std::abs(after - before) / sigma;
      largest_change = name;
    }
  };
  const char* axis[3] = {"x", "y", "z"};
  if (has_right) {
    for (int k = 0; k < 3; ++k) {
      add(StrCat("right_from_left rotation ", axis[k]), "deg", right_w0[k] * kDeg,
          right_w[k] * kDeg, sigma_of(right_w.data(), k) * kDeg, options.max_rotation_sigma_deg);
    }
    for (int k = 0; k < 3; ++k) {
      add(StrCat("right_from_left translation ", axis[k]), "mm", right_t0[k], right_t[k],
          sigma_of(right_t.data(), k), options.max_translation_sigma_mm);
    }
  }
  if (use_projector && problem.HasParameterBlock(&proj_yaw) &&
      !problem.IsParameterBlockConstant(&proj_yaw)) {
    add("projector yaw", "deg", 0, proj_yaw * kDeg, sigma_of(&proj_yaw, 0) * kDeg,
        options.max_rotation_sigma_deg);
  }
  if (use_projector && scale != RefineScale::kProjector) {
    for (int k : {0, 2}) {
      add(StrCat("projector_from_left translation ", axis[k]), "mm", proj_t0[k], proj_t[k],
          sigma_of(proj_t.data(), k), options.max_translation_sigma_mm);
    }
  }
  if (options.intrinsics) {
    const char* names[6] = {"fx", "fy", "cx", "cy", "k1", "k2"};
    for (const auto& [cam, block, block0] : {std::tuple{"left", left.data(), left0.data()},
                                             std::tuple{"right", right.data(), right0.data()}}) {
      if (!problem.HasParameterBlock(block)) continue;
      for (int k : {0, 1, 4, 5}) {
        const double limit = k < 4 ? options.max_focal_sigma_fraction * block0[0]
                                   : std::numeric_limits<double>::infinity();
        add(StrCat(cam, " ", names[k]), k < 4 ? "px" : "", block0[k], block[k], sigma_of(block, k),
            limit);
      }
    }
  }
  if (!have_sd) {
    s.status = RefineStatus::kNotDetermined;
    s.message =
        "the data do not determine the refined parameters (no covariance: the problem is "
        "rank deficient); the rig is unchanged";
    restore();
    return out;
  }
  if (!undetermined.empty() || !s.solve.converged() || !settled) {
    s.status = RefineStatus::kNotDetermined;
    s.message = "the data do not determine ";
    for (size_t i = 0; i < undetermined.size(); ++i) s.message += (i ? ", " : "") + undetermined[i];
    if (undetermined.empty() && !s.solve.converged()) {
      s.message += "the rig (the solver did not converge: " + s.solve.BriefReport() + ")";
    } else if (undetermined.empty()) {
      s.message += StrCat("the rig (after ", rounds, " solve rounds it still moved by more than ",
                          options.settle_sigmas, " of its standard deviations)");
    }
    s.message += "; the rig is unchanged";
    restore();
    return out;
  }

  StereoRig refined = rig;
  SetIntrinsicsFromBlock(left.data(), &refined.left);
  SetIntrinsicsFromBlock(right.data(), &refined.right);
  refined.right_from_left = FromBlocks(right_w.data(), right_t.data());
  if (rig.projector) {
    refined.projector_from_left = ProjectorFromBlocks(proj_w.data(), proj_yaw, proj_t.data());
  }
  // Something measurable gained? A change significant against the bundle's own uncertainty,
  // and evidence that improved.
  s.marker_epipolar_rms_after_px = MarkerEpipolarRms(refined, data.markers);
  std::vector<std::string> worse;
  bool better = false;
  // With a sphere the bend it corrects is invisible to the other kinds (header): they can only
  // stay at their noise, and the initial points may sit below it (the matcher put each where the
  // right phase matches exactly). So there a kind is worse only when it also ends above its
  // stated noise; the sphere's own RMS is the evidence that must fall.
  const bool shape = !on_sphere.empty();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const auto& [name, before, after, noise, unit] :
       {std::tuple{"markers' epipolar RMS", s.marker_epipolar_rms_before_px,
                   s.marker_epipolar_rms_after_px, kSqrt2 * options.marker_sigma_px, "px"},
        std::tuple{"right-phase RMS", s.right_phase_rms_before_px, s.right_phase_rms_after_px,
                   kSqrt2 * options.phase_sigma_px, "px"},
        std::tuple{"projector column RMS", s.projector_rms_before_px, s.projector_rms_after_px,
                   options.phase_sigma_px, "px"},
        std::tuple{"sphere radial RMS", s.sphere_rms_before_mm, s.sphere_rms_after_mm, nan,
                   "mm"}}) {
    if (!std::isfinite(before) || !std::isfinite(after)) continue;
    if (after > before && !(shape && after <= noise))
      worse.push_back(StrCat(name, " ", Fixed(before, 4), " -> ", Fixed(after, 4), " ", unit));
    if (after < options.min_evidence_ratio * before) better = true;
  }
  if (largest_change_sigmas <= options.min_change_sigmas || !worse.empty() || !better) {
    s.status = RefineStatus::kNotSignificant;
    if (largest_change_sigmas <= options.min_change_sigmas) {
      s.message = StrCat("no significant change: the largest, ", largest_change, ", moved by ",
                         Fixed(largest_change_sigmas, 2), " of its standard deviations (at least ",
                         options.min_change_sigmas, " needed)");
    } else if (!worse.empty()) {
      s.message = "the evidence got worse: ";
      for (size_t i = 0; i < worse.size(); ++i) s.message += (i ? ", " : "") + worse[i];
    } else {
      s.message = StrCat("the evidence did not improve (no residual RMS fell below ",
                         options.min_evidence_ratio, " of its initial value)");
    }
    s.message += "; the rig is unchanged";
    s.marker_epipolar_rms_after_px = s.marker_epipolar_rms_before_px;
    s.sphere_rms_after_mm = s.sphere_rms_before_mm;
    restore();
    return out;
  }
  s.status = RefineStatus::kOk;
  if (shape) {
    // The shape the refined rig measures: the sphere points triangulated again without the
    // sphere's residuals (the bundle's own points are pulled onto it).
    const RigValues refined_values{left,   right,  projector, right_w,      right_t,
                                   proj_w, proj_t, proj_yaw,  use_projector};
    std::vector<size_t> kept;
    const std::vector<Eigen::Vector3d> again =
        Retriangulate(data, on_sphere, phase, refined_values, options, &kept);
    std::vector<int> kept_sphere;
    for (size_t i : kept) kept_sphere.push_back(data.points[i].sphere);
    if (SphereShape(again, kept_sphere, centres, &s.sphere_radius_across_after_mm,
                    &s.sphere_radius_along_after_mm)) {
      s.sphere_axis_ratio_after = s.sphere_radius_along_after_mm / s.sphere_radius_across_after_mm;
    } else {
      s.sphere_axis_ratio_after = s.sphere_radius_across_after_mm = nan;
      s.sphere_radius_along_after_mm = nan;
    }
  }
  s.right_rotation_change_deg =
      refined.right_from_left.rotation().angularDistance(rig.right_from_left.rotation()) * kDeg;
  if (rig.projector) {
    s.projector_rotation_change_deg =
        refined.projector_from_left.rotation().angularDistance(rig.projector_from_left.rotation()) *
        kDeg;
  }
  s.baseline_after_mm = refined.BaselineMm();
  s.marker_epipolar_rms_after_px = MarkerEpipolarRms(refined, data.markers);
  out.rig = refined;
  return out;
}

}  // namespace fringe::calib
