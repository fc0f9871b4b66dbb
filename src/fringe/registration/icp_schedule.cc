#include "fringe/registration/icp_schedule.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "fringe/util/error.h"

namespace fringe::registration {

void IcpSchedule::Check(const char* o) const {
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
  util::CheckOption(degeneracy_ratio >= 0 && degeneracy_ratio < 1, o, "degeneracy_ratio",
                    degeneracy_ratio, "must be in [0, 1)");
  util::CheckOption(convergence_rotation_deg > 0, o, "convergence_rotation_deg",
                    convergence_rotation_deg, "must be > 0");
  util::CheckOption(convergence_translation_mm > 0, o, "convergence_translation_mm",
                    convergence_translation_mm, "must be > 0");
  util::CheckOption(convergence_step_sigmas >= 0, o, "convergence_step_sigmas",
                    convergence_step_sigmas, "must be >= 0");
}

double ShrinkThreshold(const IcpSchedule& s, double threshold_mm,
                       const std::vector<double>& residuals_mm) {
  if (residuals_mm.empty()) return threshold_mm;
  std::vector<double> a(residuals_mm.size());
  for (size_t k = 0; k < a.size(); ++k) a[k] = std::abs(residuals_mm[k]);
  const size_t q = std::min(a.size() - 1, static_cast<size_t>(s.shrink_percentile * a.size()));
  std::nth_element(a.begin(), a.begin() + q, a.end());
  return std::max(s.min_threshold_mm, std::min(threshold_mm, s.shrink_factor * a[q]));
}

IcpStep DegeneracyAwareStep(const Eigen::MatrixXd& H, const Eigen::VectorXd& g, double lever_mm,
                            double degeneracy_ratio, double residual_rms_mm) {
  const int dim = static_cast<int>(g.size());
  Eigen::VectorXd scale = Eigen::VectorXd::Ones(dim);
  for (int b = 0; b + 6 <= dim; b += 6) scale.segment<3>(b).setConstant(1.0 / lever_mm);
  const Eigen::MatrixXd Hs = scale.asDiagonal() * H * scale.asDiagonal();
  const Eigen::VectorXd gs = scale.cwiseProduct(g);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(Hs);
  const double lmax = eig.eigenvalues().maxCoeff();
  Eigen::VectorXd ds = Eigen::VectorXd::Zero(dim);
  IcpStep step;
  double chi2 = 0;
  for (int k = 0; k < dim; ++k) {
    const double l = eig.eigenvalues()[k];
    if (!(l > degeneracy_ratio * lmax)) {
      ++step.degenerate;
      continue;
    }
    const double proj = eig.eigenvectors().col(k).dot(gs);
    ds -= eig.eigenvectors().col(k) * (proj / l);
    chi2 += proj * proj / l;  // l x (proj / l)^2: the step's part of x^T H x
  }
  step.delta = scale.cwiseProduct(ds);
  const int moved = dim - step.degenerate;
  step.step_sigmas =
      moved > 0 && residual_rms_mm > 0 ? std::sqrt(chi2 / moved) / residual_rms_mm : 0.0;
  return step;
}

IcpScheduleOutcome RunIcpSchedule(const IcpSchedule& s, const IcpIterateFn& iterate,
                                  std::vector<IcpLevelReport>* levels) {
  double threshold = s.initial_threshold_mm;
  bool all_converged = true;
  for (size_t level = 0; level < s.points_per_level.size(); ++level) {
    IcpLevelReport rep;
    rep.level = static_cast<int>(level);
    rep.points_per_view = s.points_per_level[level];
    rep.threshold_start_mm = threshold;
    // A coarse level only has to hand the next one a start within what the next one resolves
    // (see the header): the next level's deviation is sqrt(points / next points) of its own.
    double step_sigmas = s.convergence_step_sigmas;
    if (s.coarse_levels_to_next_sigma && step_sigmas > 0 && level + 1 < s.points_per_level.size()) {
      step_sigmas = std::max(step_sigmas, std::sqrt(static_cast<double>(s.points_per_level[level]) /
                                                    s.points_per_level[level + 1]));
    }
    std::vector<double> last;
    for (int it = 0; it < s.max_iterations_per_level; ++it) {
      IcpIteration r = iterate(s.points_per_level[level], threshold, &rep);
      if (!r.overlap) {
        rep.threshold_end_mm = threshold;
        levels->push_back(std::move(rep));
        return IcpScheduleOutcome::kNoOverlap;
      }
      if (it == 0) rep.rms_start_mm = r.rms_mm;
      rep.rms_end_mm = r.rms_mm;
      rep.iterations = it + 1;
      rep.last_step_rotation_deg = r.step_rotation_deg;
      rep.last_step_translation_mm = r.step_translation_mm;
      rep.last_step_sigmas = r.step_sigmas;
      last = std::move(r.residuals_mm);
      if (s.shrink_within_level) threshold = ShrinkThreshold(s, threshold, last);
      if ((r.step_rotation_deg < s.convergence_rotation_deg &&
           r.step_translation_mm < s.convergence_translation_mm) ||
          r.step_sigmas < step_sigmas) {
        rep.converged = true;
        break;
      }
    }
    if (!last.empty()) {
      // Three selections instead of a sort (the last level has ~1e6 residuals).
      std::vector<double> a(last.size());
      for (size_t k = 0; k < last.size(); ++k) a[k] = std::abs(last[k]);
      const auto at = [&](double q) {
        const auto nth = a.begin() + std::min(a.size() - 1, static_cast<size_t>(q * a.size()));
        std::nth_element(a.begin(), nth, a.end());
        return *nth;
      };
      rep.residual_p50_mm = at(0.5);
      rep.residual_p90_mm = at(0.9);
      rep.residual_p99_mm = at(0.99);
      const size_t stride = last.size() / kReportedResiduals + 1;
      for (size_t k = 0; k < last.size(); k += stride) {
        rep.residuals_mm.push_back(static_cast<float>(last[k]));
      }
    }
    // Per level: shrinking within a level would cut the correspondences that still carry the
    // misalignment (on a plane-dominated scene the percentile is the plate's noise while the
    // walls still see the view's slide).
    if (!s.shrink_within_level) threshold = ShrinkThreshold(s, threshold, last);
    rep.threshold_end_mm = threshold;
    all_converged &= rep.converged;
    levels->push_back(std::move(rep));
  }
  return all_converged ? IcpScheduleOutcome::kConverged : IcpScheduleOutcome::kNotConverged;
}

}  // namespace fringe::registration
