#include "fringe/calib/bundle.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"

namespace fringe::calib {
namespace {

CameraModel DistortedCamera() {
  CameraModel c = CameraModel::ReferenceCamera();
  c.k1 = -0.2;
  c.k2 = 0.15;
  c.p1 = 1e-3;
  c.p2 = -5e-4;
  c.k3 = 0.02;
  return c;
}

// The templated model (used with automatic derivatives) is CameraModel::Project.
TEST(Bundle, TemplatedProjectionEqualsCameraModel) {
  constexpr double kTolPx = 1e-9;
  const CameraModel cam = DistortedCamera();
  const IntrinsicsBlock intrinsics = IntrinsicsBlockOf(cam);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-150, 150), z(300, 900);
  for (int i = 0; i < 200; ++i) {
    const double p[3] = {u(rng), u(rng), z(rng)};
    double pixel[2];
    ASSERT_TRUE(ProjectWithIntrinsics(intrinsics.data(), p, pixel));
    const Eigen::Vector2d expected = cam.Project(Eigen::Vector3d(p[0], p[1], p[2]));
    EXPECT_NEAR(pixel[0], expected.x(), kTolPx);
    EXPECT_NEAR(pixel[1], expected.y(), kTolPx);
  }
  const double behind[3] = {1, 2, -5};
  double pixel[2];
  EXPECT_FALSE(ProjectWithIntrinsics(intrinsics.data(), behind, pixel));
}

TEST(Bundle, PoseBlockRoundTrip) {
  constexpr double kTol = 1e-12;
  const Rigid3d pose =
      Rigid3d::FromAxisAngle(Eigen::Vector3d(0.3, -1, 0.5), 2.1, Eigen::Vector3d(10, -20, 500));
  const PoseBlock block = PoseBlockOf(pose);
  const auto diff = Difference(RigidFromPoseBlock(block.data()), pose);
  EXPECT_LT(diff.angle_rad, kTol);
  EXPECT_LT(diff.translation_mm, 1e-9);
  // The templated transform agrees with Rigid3d.
  const Eigen::Vector3d p(12, -7, 30);
  double q[3];
  TransformPoint(block.data(), p.data(), q);
  EXPECT_LT((Eigen::Vector3d(q[0], q[1], q[2]) - pose * p).norm(), 1e-9);
  const PoseBlock identity = PoseBlockOf(Rigid3d());
  for (double v : identity) EXPECT_EQ(v, 0.0);
}

// Automatic derivatives of the chained cost agree with Ridders' extrapolated differences.
TEST(Bundle, ChainedCostJacobianMatchesNumeric) {
  constexpr double kRelTol = 1e-6;
  const CameraModel cam = DistortedCamera();
  IntrinsicsBlock intrinsics = IntrinsicsBlockOf(cam);
  PoseBlock device_from_reference = PoseBlockOf(
      Rigid3d::FromAxisAngle(Eigen::Vector3d(0, 1, 0), 0.3, Eigen::Vector3d(-200, 5, 30)));
  PoseBlock reference_from_board = PoseBlockOf(
      Rigid3d::FromAxisAngle(Eigen::Vector3d(1, 0.2, 0), 0.4, Eigen::Vector3d(-60, -40, 520)));
  const Eigen::Vector3d p_in_board(48, 72, 0);
  std::unique_ptr<ceres::CostFunction> autodiff(
      ChainedReprojectionCost::Create(p_in_board, Eigen::Vector2d(600, 500)));
  ceres::NumericDiffOptions nd;
  nd.ridders_relative_initial_step_size = 1e-3;
  ceres::NumericDiffCostFunction<ChainedReprojectionCost, ceres::RIDDERS, 2, kNumIntrinsics,
                                 kPoseBlockSize, kPoseBlockSize>
      numeric(new ChainedReprojectionCost(p_in_board, Eigen::Vector2d(600, 500)),
              ceres::TAKE_OWNERSHIP, 2, nd);
  const double* params[3] = {intrinsics.data(), device_from_reference.data(),
                             reference_from_board.data()};
  const int sizes[3] = {kNumIntrinsics, kPoseBlockSize, kPoseBlockSize};
  double r_auto[2], r_num[2];
  std::vector<std::vector<double>> j_auto(3), j_num(3);
  double* ja[3];
  double* jn[3];
  for (int b = 0; b < 3; ++b) {
    j_auto[b].resize(2 * sizes[b]);
    j_num[b].resize(2 * sizes[b]);
    ja[b] = j_auto[b].data();
    jn[b] = j_num[b].data();
  }
  ASSERT_TRUE(autodiff->Evaluate(params, r_auto, ja));
  ASSERT_TRUE(numeric.Evaluate(params, r_num, jn));
  EXPECT_DOUBLE_EQ(r_auto[0], r_num[0]);
  EXPECT_DOUBLE_EQ(r_auto[1], r_num[1]);
  for (int b = 0; b < 3; ++b) {
    for (size_t k = 0; k < j_auto[b].size(); ++k) {
      EXPECT_NEAR(j_auto[b][k], j_num[b][k], kRelTol * (1 + std::abs(j_auto[b][k])))
          << "block " << b << " entry " << k;
    }
  }
}

// Line fit y = a x + b: the standard deviations equal the textbook ones,
// sqrt(diag(s^2 (X^T X)^-1)) with s^2 = SSE / (m - 2).
struct LineResidual {
  LineResidual(double x, double y) : x(x), y(y) {}
  template <typename T>
  bool operator()(const T* ab, T* r) const {
    r[0] = ab[0] * T(x) + ab[1] - T(y);
    return true;
  }
  double x, y;
};

TEST(Bundle, StandardDeviationsOfALineFit) {
  constexpr double kRelTol = 1e-8;
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0, 0.3);
  const int m = 40;
  Eigen::MatrixXd x(m, 2);
  Eigen::VectorXd y(m);
  double ab[2] = {0, 0};
  ceres::Problem problem;
  for (int i = 0; i < m; ++i) {
    x(i, 0) = i * 0.25;
    x(i, 1) = 1;
    y(i) = 1.7 * x(i, 0) - 3 + noise(rng);
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<LineResidual, 1, 2>(new LineResidual(x(i, 0), y(i))),
        nullptr, ab);
  }
  const SolveReport report = Solve(SolveOptions(), &problem);
  ASSERT_TRUE(report.converged()) << report.BriefReport();
  const Eigen::Vector2d fit = (x.transpose() * x).ldlt().solve(x.transpose() * y);
  EXPECT_NEAR(ab[0], fit(0), 1e-9);
  EXPECT_NEAR(ab[1], fit(1), 1e-9);
  const double s2 = (x * fit - y).squaredNorm() / (m - 2);
  const Eigen::Matrix2d cov = s2 * (x.transpose() * x).inverse();
  std::vector<std::vector<double>> std_devs;
  ASSERT_TRUE(StandardDeviations(&problem, {ab}, &std_devs));
  EXPECT_NEAR(std_devs[0][0], std::sqrt(cov(0, 0)), kRelTol * std::sqrt(cov(0, 0)));
  EXPECT_NEAR(std_devs[0][1], std::sqrt(cov(1, 1)), kRelTol * std::sqrt(cov(1, 1)));
  // A coordinate held fixed by a manifold has no spread; the other is then a 1-parameter fit.
  problem.SetManifold(ab, new ceres::SubsetManifold(2, {1}));
  ASSERT_TRUE(StandardDeviations(&problem, {ab}, &std_devs));
  EXPECT_EQ(std_devs[0][1], 0.0);
  EXPECT_GT(std_devs[0][0], 0.0);
}

// A solve stopped by the iteration limit is not a success.
TEST(Bundle, IterationLimitIsNoConvergence) {
  CameraModel truth = DistortedCamera();
  IntrinsicsBlock intrinsics = IntrinsicsBlockOf(truth);
  intrinsics[0] *= 1.05;
  intrinsics[2] += 20;
  PoseBlock pose = PoseBlockOf(Rigid3d(Eigen::Quaterniond::Identity(), {-80, -60, 600}));
  const Rigid3d true_pose =
      Rigid3d::FromAxisAngle(Eigen::Vector3d(1, 1, 0), 0.3, Eigen::Vector3d(-90, -70, 560));
  ceres::Problem problem;
  for (int r = 0; r < 7; ++r) {
    for (int c = 0; c < 9; ++c) {
      const Eigen::Vector3d p(24.0 * c, 24.0 * r, 0);
      problem.AddResidualBlock(BoardReprojectionCost::Create(p, truth.Project(true_pose * p)),
                               nullptr, intrinsics.data(), pose.data());
    }
  }
  // One view cannot separate focal length and distance well: fix the distortion.
  problem.SetManifold(intrinsics.data(), NewIntrinsicsManifold({true, true, true, true, false,
                                                                false, false, false, false}));
  SolveOptions options;
  options.max_iterations = 1;
  const SolveReport limited = Solve(options, &problem);
  EXPECT_EQ(limited.termination, ceres::NO_CONVERGENCE) << limited.BriefReport();
  EXPECT_FALSE(limited.converged());
  EXPECT_NE(limited.BriefReport().find("NO_CONVERGENCE"), std::string::npos);
}

TEST(Bundle, OptionsCheck) {
  EXPECT_NO_THROW(SolveOptions().Check());
  SolveOptions o;
  o.max_iterations = 0;
  EXPECT_THROW(o.Check(), Error);
  EXPECT_EQ(NewLossFunction(RobustLoss::kNone, 1), nullptr);
  std::unique_ptr<ceres::LossFunction> huber(NewLossFunction(RobustLoss::kHuber, 1));
  double rho[3];
  huber->Evaluate(9.0, rho);  // squared error 9 px^2, beyond the 1 px scale: linear
  EXPECT_NEAR(rho[0], 2 * 3 - 1, 1e-12);
  EXPECT_EQ(
      NewIntrinsicsManifold(FreeIntrinsics{true, true, true, true, true, true, true, true, true}),
      nullptr);
}

}  // namespace
}  // namespace fringe::calib
