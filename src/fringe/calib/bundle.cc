#include "fringe/calib/bundle.h"

#include <Eigen/Geometry>
#include <cmath>
#include <memory>
#include <sstream>

#include "fringe/util/error.h"

namespace fringe::calib {

IntrinsicsBlock IntrinsicsBlockOf(const CameraModel& c) {
  return {c.fx, c.fy, c.cx, c.cy, c.k1, c.k2, c.p1, c.p2, c.k3};
}

void SetIntrinsicsFromBlock(const double* x, CameraModel* c) {
  c->fx = x[0];
  c->fy = x[1];
  c->cx = x[2];
  c->cy = x[3];
  c->SetDistortion({x[4], x[5], x[6], x[7], x[8]});
}

PoseBlock PoseBlockOf(const Rigid3d& b_from_a) {
  const Eigen::AngleAxisd aa(b_from_a.rotation());
  const Eigen::Vector3d w = aa.axis() * aa.angle();
  const Eigen::Vector3d& t = b_from_a.translation();
  return {w.x(), w.y(), w.z(), t.x(), t.y(), t.z()};
}

Rigid3d RigidFromPoseBlock(const double* block) {
  const Eigen::Vector3d w(block[0], block[1], block[2]);
  const Eigen::Vector3d t(block[3], block[4], block[5]);
  const double angle_rad = w.norm();
  if (angle_rad < 1e-300) return Rigid3d(Eigen::Quaterniond::Identity(), t);
  return Rigid3d::FromAxisAngle(w / angle_rad, angle_rad, t);
}

ceres::Manifold* NewIntrinsicsManifold(const FreeIntrinsics& free) {
  std::vector<int> fixed;
  for (int k = 0; k < kNumIntrinsics; ++k) {
    if (!free[k]) fixed.push_back(k);
  }
  if (fixed.empty()) return nullptr;
  return new ceres::SubsetManifold(kNumIntrinsics, fixed);
}

const char* RobustLossName(RobustLoss loss) {
  switch (loss) {
    case RobustLoss::kNone:
      return "none";
    case RobustLoss::kHuber:
      return "huber";
    case RobustLoss::kCauchy:
      return "cauchy";
  }
  return "?";
}

ceres::LossFunction* NewLossFunction(RobustLoss loss, double scale) {
  switch (loss) {
    case RobustLoss::kNone:
      return nullptr;
    case RobustLoss::kHuber:
      return new ceres::HuberLoss(scale);
    case RobustLoss::kCauchy:
      return new ceres::CauchyLoss(scale);
  }
  return nullptr;
}

void SolveOptions::Check() const {
  using util::CheckOption;
  const char* o = "SolveOptions";
  CheckOption(max_iterations >= 1, o, "max_iterations", max_iterations, "must be >= 1");
  CheckOption(function_tolerance > 0, o, "function_tolerance", function_tolerance, "must be > 0");
  CheckOption(parameter_tolerance > 0, o, "parameter_tolerance", parameter_tolerance,
              "must be > 0");
  CheckOption(gradient_tolerance > 0, o, "gradient_tolerance", gradient_tolerance, "must be > 0");
}

std::string SolveReport::BriefReport() const {
  std::ostringstream os;
  os << ceres::TerminationTypeToString(termination) << " after " << iterations
     << " iterations, cost " << initial_cost << " -> " << final_cost << " (" << num_residuals
     << " residuals, " << num_free_parameters << " parameters)";
  if (!converged() && !message.empty()) os << ": " << message;
  return os.str();
}

SolveReport Solve(const SolveOptions& options, ceres::Problem* problem) {
  options.Check();
  ceres::Solver::Options so;
  so.minimizer_type = ceres::TRUST_REGION;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.linear_solver_type = ceres::DENSE_SCHUR;
  so.max_num_iterations = options.max_iterations;
  so.function_tolerance = options.function_tolerance;
  so.parameter_tolerance = options.parameter_tolerance;
  so.gradient_tolerance = options.gradient_tolerance;
  so.num_threads = 1;  // thread-count independent results (header)
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary summary;
  ceres::Solve(so, problem, &summary);
  SolveReport r;
  r.termination = summary.termination_type;
  r.message = summary.message;
  r.iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
  r.initial_cost = summary.initial_cost;
  r.final_cost = summary.final_cost;
  r.num_residuals = summary.num_residuals_reduced;
  r.num_free_parameters = summary.num_effective_parameters_reduced;
  if (r.converged() && !std::isfinite(r.final_cost)) {
    r.termination = ceres::FAILURE;
    r.message = "cost not finite";
  }
  return r;
}

namespace {

// Free parameters of a problem: tangent sizes of its variable blocks.
int FreeParameters(const ceres::Problem& problem) {
  std::vector<double*> blocks;
  problem.GetParameterBlocks(&blocks);
  int n = 0;
  for (double* b : blocks) {
    if (!problem.IsParameterBlockConstant(b)) n += problem.ParameterBlockTangentSize(b);
  }
  return n;
}

}  // namespace

bool StandardDeviations(ceres::Problem* problem, const std::vector<const double*>& blocks,
                        std::vector<std::vector<double>>* std_devs, Eigen::MatrixXd* covariance) {
  std_devs->assign(blocks.size(), {});
  if (covariance) covariance->resize(0, 0);
  for (size_t i = 0; i < blocks.size(); ++i) {
    (*std_devs)[i].assign(problem->ParameterBlockSize(blocks[i]), 0.0);
  }
  // sigma^2 from the unrobustified residuals: the scatter of the observations themselves.
  ceres::Problem::EvaluateOptions eo;
  eo.apply_loss_function = false;
  double cost = 0;
  if (!problem->Evaluate(eo, &cost, nullptr, nullptr, nullptr)) return false;
  const int m = problem->NumResiduals();
  const int n = FreeParameters(*problem);
  if (m <= n) return false;
  const double sigma2 = 2 * cost / (m - n);

  std::vector<std::pair<const double*, const double*>> pairs;
  for (size_t i = 0; i < blocks.size(); ++i) {
    if (problem->IsParameterBlockConstant(const_cast<double*>(blocks[i]))) continue;
    pairs.emplace_back(blocks[i], blocks[i]);
    if (!covariance) continue;
    for (size_t j = i + 1; j < blocks.size(); ++j) {
      if (!problem->IsParameterBlockConstant(const_cast<double*>(blocks[j]))) {
        pairs.emplace_back(blocks[i], blocks[j]);
      }
    }
  }
  if (pairs.empty()) return true;
  ceres::Covariance::Options co;
  co.num_threads = 1;
  co.apply_loss_function = false;
  std::unique_ptr<ceres::Covariance> cov(new ceres::Covariance(co));
  if (!cov->Compute(pairs, problem)) {
    co.algorithm_type = ceres::DENSE_SVD;
    co.null_space_rank = -1;  // drop directions the data do not determine
    cov.reset(new ceres::Covariance(co));
    if (!cov->Compute(pairs, problem)) return false;
  }
  for (size_t i = 0; i < blocks.size(); ++i) {
    if (problem->IsParameterBlockConstant(const_cast<double*>(blocks[i]))) continue;
    const int size = problem->ParameterBlockSize(blocks[i]);
    std::vector<double> c(size * size);
    if (!cov->GetCovarianceBlock(blocks[i], blocks[i], c.data())) return false;
    for (int k = 0; k < size; ++k) {
      (*std_devs)[i][k] = std::sqrt(std::max(0.0, sigma2 * c[k * size + k]));
    }
  }
  if (covariance) {
    // The joint matrix in the order of `blocks` (zero rows and columns for constant blocks).
    std::vector<int> offset(blocks.size() + 1, 0);
    for (size_t i = 0; i < blocks.size(); ++i) {
      offset[i + 1] = offset[i] + problem->ParameterBlockSize(blocks[i]);
    }
    Eigen::MatrixXd joint = Eigen::MatrixXd::Zero(offset.back(), offset.back());
    for (size_t i = 0; i < blocks.size(); ++i) {
      if (problem->IsParameterBlockConstant(const_cast<double*>(blocks[i]))) continue;
      for (size_t j = i; j < blocks.size(); ++j) {
        if (problem->IsParameterBlockConstant(const_cast<double*>(blocks[j]))) continue;
        const int ni = offset[i + 1] - offset[i], nj = offset[j + 1] - offset[j];
        Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> c(ni, nj);
        if (!cov->GetCovarianceBlock(blocks[i], blocks[j], c.data())) return false;
        joint.block(offset[i], offset[j], ni, nj) = sigma2 * c;
        joint.block(offset[j], offset[i], nj, ni) = sigma2 * c.transpose();
      }
    }
    *covariance = std::move(joint);
  }
  return true;
}

}  // namespace fringe::calib
