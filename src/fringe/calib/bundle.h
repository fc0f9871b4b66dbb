// Reusable parts of bundle adjustment on Ceres Solver: the camera model as a cost functor
// templated on the scalar (automatic derivatives), the pose parametrisation, robust losses,
// the solve with its termination, and standard deviations from ceres::Covariance.
//
// Used by the camera / stereo / projector calibration (calibrate.h); meant for every sparse
// least-squares problem of the project (registration's global marker adjustment: marker map +
// view poses), so that there is one parametrisation and one covariance convention.
//
// Parameter blocks:
//   intrinsics  double[9]: fx fy cx cy k1 k2 p1 p2 k3 (pixels; distortion dimensionless), the
//               model of geometry/camera.h; coordinates held fixed through IntrinsicsManifold.
//   pose        double[6]: b_from_a as a rotation vector (axis * angle, rad) then a translation
//               (mm): p_in_b = R(w) p_in_a + t. Euclidean (no manifold): the rotation vector is
//               smooth away from angle pi, which board and rig poses never reach, and its
//               standard deviations read directly as radians about x, y, z.
//
// Frames: a device (camera or projector, an inverse camera) observes board points through
// device_from_board = device_from_reference * reference_from_board; the reference device (the
// first camera) has no device_from_reference block (BoardReprojectionCost), every other device
// one (ChainedReprojectionCost). N cameras + a projector are the same code.
//
// Determinism: Solve runs Ceres single-threaded (its Schur complement accumulates in a
// thread-dependent order), so results do not depend on the machine's thread count.
// Thread safety: the functions are reentrant; a ceres::Problem is used by one thread.
#pragma once

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "fringe/geometry/camera.h"
#include "fringe/geometry/rigid3.h"

namespace fringe::calib {

// Layout of an intrinsics block and of CameraCalibration::std_dev.
constexpr int kNumIntrinsics = 9;
constexpr int kPoseBlockSize = 6;
using IntrinsicsBlock = std::array<double, kNumIntrinsics>;
using PoseBlock = std::array<double, kPoseBlockSize>;

IntrinsicsBlock IntrinsicsBlockOf(const CameraModel& camera);
// Sets fx .. k3 of *camera from a block; width and height stay.
void SetIntrinsicsFromBlock(const double* block, CameraModel* camera);

PoseBlock PoseBlockOf(const Rigid3d& b_from_a);
Rigid3d RigidFromPoseBlock(const double* block);

// p_in_b = b_from_a * p_in_a for a pose block on any scalar type.
template <typename T>
void TransformPoint(const T* b_from_a, const T* p_in_a, T* p_in_b) {
  ceres::AngleAxisRotatePoint(b_from_a, p_in_a, p_in_b);
  for (int i = 0; i < 3; ++i) p_in_b[i] += b_from_a[3 + i];
}

// Pixel of a point in the device frame through an intrinsics block: CameraModel::Project on any
// scalar type. Returns false for points at or behind the projection centre (Z <= 0), which
// makes Ceres reject the step.
template <typename T>
bool ProjectWithIntrinsics(const T* intrinsics, const T* p_in_device, T* pixel) {
  if (!(p_in_device[2] > T(0))) return false;
  const T x = p_in_device[0] / p_in_device[2];
  const T y = p_in_device[1] / p_in_device[2];
  T xd, yd;
  DistortNormalized(intrinsics + 4, x, y, &xd, &yd);
  pixel[0] = intrinsics[0] * xd + intrinsics[2];
  pixel[1] = intrinsics[1] * yd + intrinsics[3];
  return true;
}

// Residual (pixels, 2) = projection of a point in the device frame - observed; false behind the
// device (ProjectWithIntrinsics). The tail of both board costs below.
template <typename T>
bool ReprojectionResidual(const T* intrinsics, const T* p_in_device,
                          const Eigen::Vector2d& observed_px, T* residual) {
  T pixel[2];
  if (!ProjectWithIntrinsics(intrinsics, p_in_device, pixel)) return false;
  residual[0] = pixel[0] - T(observed_px.x());
  residual[1] = pixel[1] - T(observed_px.y());
  return true;
}

// Residual (pixels, 2) = projection of a board point seen by the reference device - observed.
// Blocks: intrinsics[9], reference_from_board[6].
struct BoardReprojectionCost {
  BoardReprojectionCost(const Eigen::Vector3d& p_in_board, const Eigen::Vector2d& observed_px)
      : p_in_board(p_in_board), observed_px(observed_px) {}

  template <typename T>
  bool operator()(const T* intrinsics, const T* device_from_board, T* residual) const {
    const T p[3] = {T(p_in_board.x()), T(p_in_board.y()), T(p_in_board.z())};
    T p_in_device[3];
    TransformPoint(device_from_board, p, p_in_device);
    return ReprojectionResidual(intrinsics, p_in_device, observed_px, residual);
  }

  static ceres::CostFunction* Create(const Eigen::Vector3d& p_in_board,
                                     const Eigen::Vector2d& observed_px) {
    return new ceres::AutoDiffCostFunction<BoardReprojectionCost, 2, kNumIntrinsics,
                                           kPoseBlockSize>(
        new BoardReprojectionCost(p_in_board, observed_px));
  }

  Eigen::Vector3d p_in_board;
  Eigen::Vector2d observed_px;
};

// The same for any other device (second camera, projector). Blocks: intrinsics[9],
// device_from_reference[6], reference_from_board[6].
struct ChainedReprojectionCost {
  ChainedReprojectionCost(const Eigen::Vector3d& p_in_board, const Eigen::Vector2d& observed_px)
      : p_in_board(p_in_board), observed_px(observed_px) {}

  template <typename T>
  bool operator()(const T* intrinsics, const T* device_from_reference,
                  const T* reference_from_board, T* residual) const {
    const T p[3] = {T(p_in_board.x()), T(p_in_board.y()), T(p_in_board.z())};
    T p_in_reference[3], p_in_device[3];
    TransformPoint(reference_from_board, p, p_in_reference);
    TransformPoint(device_from_reference, p_in_reference, p_in_device);
    return ReprojectionResidual(intrinsics, p_in_device, observed_px, residual);
  }

  static ceres::CostFunction* Create(const Eigen::Vector3d& p_in_board,
                                     const Eigen::Vector2d& observed_px) {
    return new ceres::AutoDiffCostFunction<ChainedReprojectionCost, 2, kNumIntrinsics,
                                           kPoseBlockSize, kPoseBlockSize>(
        new ChainedReprojectionCost(p_in_board, observed_px));
  }

  Eigen::Vector3d p_in_board;
  Eigen::Vector2d observed_px;
};

// Which of fx fy cx cy k1 k2 p1 p2 k3 are estimated.
using FreeIntrinsics = std::array<bool, kNumIntrinsics>;

// Manifold holding the coordinates that are not free at their current values; nullptr when all
// are free (the caller passes it to Problem::SetManifold, which takes ownership).
ceres::Manifold* NewIntrinsicsManifold(const FreeIntrinsics& free);

enum class RobustLoss {
  kNone,    // least squares
  kHuber,   // quadratic below the scale, linear above
  kCauchy,  // log(1 + s^2): strong down-weighting of gross errors
};
const char* RobustLossName(RobustLoss loss);
// Loss on the squared norm of one residual block; scale in the residual's unit (e.g. pixels).
// nullptr for kNone (Ceres' least squares). The problem takes ownership.
ceres::LossFunction* NewLossFunction(RobustLoss loss, double scale);

struct SolveOptions {
  int max_iterations = 200;            // trust-region iterations, >= 1
  double function_tolerance = 1e-12;   // relative cost change at convergence, > 0
  double parameter_tolerance = 1e-12;  // relative step size at convergence, > 0
  double gradient_tolerance = 1e-14;   // max-norm of the projected gradient, > 0
  void Check() const;
};

// Outcome of one Ceres solve. CONVERGENCE is the only success: NO_CONVERGENCE (iteration limit)
// and FAILURE (numerical failure, cost not finite) are reported failures.
struct SolveReport {
  ceres::TerminationType termination = ceres::FAILURE;
  std::string message;                      // Ceres' summary message
  int iterations = 0;                       // successful + unsuccessful steps
  double initial_cost = 0, final_cost = 0;  // Ceres' cost: 0.5 * sum of (robustified) squares
  int num_residuals = 0;
  int num_free_parameters = 0;  // effective (tangent space) parameters
  bool converged() const { return termination == ceres::CONVERGENCE; }
  std::string BriefReport() const;
};

// Levenberg-Marquardt, Schur elimination of the pose blocks that touch one residual each
// (DENSE_SCHUR; Ceres finds the elimination order), single-threaded (header).
SolveReport Solve(const SolveOptions& options, ceres::Problem* problem);

// Standard deviations of parameter blocks: sqrt(diag(sigma^2 (J^T J)^-1)) at the optimum in
// each block's ambient coordinates (0 for coordinates held fixed by a manifold and for constant
// blocks), sigma^2 = sum of squared residuals / (residuals - free parameters), the unit
// weight's variance estimated from the fit. ceres::Covariance with SPARSE_QR; if the Jacobian is
// rank deficient, DENSE_SVD with the null space dropped (a pseudo-inverse). Returns false
// (std_devs zero) when neither works or the problem has no redundancy. With `covariance`, also
// the joint covariance of all the blocks (sigma^2 (J^T J)^-1 with the cross terms; rows and
// columns in the order of `blocks`, each block's ambient coordinates; empty on failure): what
// propagating the calibration's uncertainty into a measurement needs (the parameters are
// strongly correlated, e.g. a focal length with the translation).
bool StandardDeviations(ceres::Problem* problem, const std::vector<const double*>& blocks,
                        std::vector<std::vector<double>>* std_devs,
                        Eigen::MatrixXd* covariance = nullptr);

}  // namespace fringe::calib
