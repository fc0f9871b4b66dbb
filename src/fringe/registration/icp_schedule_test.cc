#include "fringe/registration/icp_schedule.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>

#include "fringe/util/error.h"

namespace fringe::registration {
namespace {

TEST(IcpSchedule, DefaultsPassCheckAndBadFieldsAreNamed) {
  EXPECT_NO_THROW(IcpSchedule().Check("IcpSchedule"));
  IcpSchedule s;
  s.min_threshold_mm = 2 * s.initial_threshold_mm;
  try {
    s.Check("Owner");
    ADD_FAILURE() << "accepted min_threshold_mm > initial_threshold_mm";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("min_threshold_mm"), std::string::npos) << e.what();
  }
}

// min(previous, 5 x the 80th percentile of |r|), never below the floor.
TEST(IcpSchedule, ShrinkThresholdIsMeshLabsRule) {
  IcpSchedule s;
  s.min_threshold_mm = 0.05;
  std::vector<double> r;
  for (int k = 0; k < 100; ++k) r.push_back((k % 2 ? -1 : 1) * 0.001 * k);  // |r| = 0 .. 0.099
  EXPECT_NEAR(ShrinkThreshold(s, 1.0, r), 5 * 0.080, 1e-12);
  EXPECT_EQ(ShrinkThreshold(s, 0.3, r), 0.3);  // never grows
  for (double& x : r) x /= 100;
  EXPECT_EQ(ShrinkThreshold(s, 1.0, r), 0.05);  // the floor
  EXPECT_EQ(ShrinkThreshold(s, 1.0, {}), 1.0);  // nothing measured: unchanged
}

// A normal matrix that constrains five directions and not the sixth: the step solves the five
// and leaves the sixth at zero; its size in sigmas is sqrt(x^T H x / (rms^2 x 5)).
TEST(IcpSchedule, DegeneracyAwareStepHoldsUnconstrainedDirections) {
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(6, 6);
  H.diagonal() << 4, 4, 0, 9, 9, 9;  // rotation about z unconstrained (a plane)
  Eigen::VectorXd g(6);
  g << 0.4, -0.8, 0.5, 0.9, 0, -1.8;
  const IcpStep step = DegeneracyAwareStep(H, g, 1.0, 1e-6, 0.1);
  EXPECT_EQ(step.degenerate, 1);
  EXPECT_NEAR(step.delta[0], -0.1, 1e-12);
  EXPECT_NEAR(step.delta[1], 0.2, 1e-12);
  EXPECT_EQ(step.delta[2], 0.0);
  EXPECT_NEAR(step.delta[3], -0.1, 1e-12);
  EXPECT_NEAR(step.delta[5], 0.2, 1e-12);
  const double xhx = step.delta.dot(H * step.delta);
  EXPECT_NEAR(step.step_sigmas, std::sqrt(xhx / 5) / 0.1, 1e-12);
}

// A fake ICP whose steps shrink geometrically to a noise floor of 0.05 sigma (re-association
// jitter) but never below 3e-4 mm: the fixed limits (1e-4) alone would run into the iteration
// limit; the statistical test stops the level.
TEST(IcpSchedule, LevelsConvergeOnStepsBelowTheEstimatesUncertainty) {
  IcpSchedule s;
  s.points_per_level = {100, 400};
  s.max_iterations_per_level = 15;
  s.initial_threshold_mm = 1;
  int calls = 0;
  const auto iterate = [&](int, double, IcpLevelReport*) {
    IcpIteration it;
    it.overlap = true;
    it.residuals_mm.assign(50, 0.01);
    it.rms_mm = 0.01;
    it.step_translation_mm = std::max(3e-4, 0.1 * std::pow(0.3, calls));
    it.step_rotation_deg = it.step_translation_mm;
    it.step_sigmas = std::max(0.05, 10 * std::pow(0.3, calls));
    ++calls;
    return it;
  };
  std::vector<IcpLevelReport> levels;
  s.convergence_step_sigmas = 0;
  EXPECT_EQ(RunIcpSchedule(s, iterate, &levels), IcpScheduleOutcome::kNotConverged);
  EXPECT_EQ(levels[0].iterations, 15);
  calls = 0;
  levels.clear();
  s.convergence_step_sigmas = 0.1;
  EXPECT_EQ(RunIcpSchedule(s, iterate, &levels), IcpScheduleOutcome::kConverged);
  ASSERT_EQ(levels.size(), 2u);
  EXPECT_LT(levels[0].iterations, 10);
  EXPECT_TRUE(levels[0].converged);
  EXPECT_LT(levels[0].last_step_sigmas, 0.1);
  // Per level (the default) the threshold shrinks once, to 5 x the 80th percentile.
  EXPECT_EQ(levels[0].threshold_start_mm, 1.0);
  EXPECT_NEAR(levels[0].threshold_end_mm, 0.05, 1e-12);
  EXPECT_EQ(levels[1].threshold_start_mm, levels[0].threshold_end_mm);
}

TEST(IcpSchedule, NoOverlapStopsWithTheLevelReported) {
  IcpSchedule s;
  std::vector<IcpLevelReport> levels;
  const auto none = [](int, double, IcpLevelReport*) { return IcpIteration(); };
  EXPECT_EQ(RunIcpSchedule(s, none, &levels), IcpScheduleOutcome::kNoOverlap);
  ASSERT_EQ(levels.size(), 1u);
  EXPECT_EQ(levels[0].threshold_end_mm, s.initial_threshold_mm);
}

}  // namespace
}  // namespace fringe::registration
