// Least-squares rigid alignment of corresponding 3D point sets (Arun / Horn / Umeyama, without
// scale), with optional per-pair weights.
//
// Reference: S. Umeyama, "Least-squares estimation of transformation parameters between two point
// patterns", IEEE TPAMI 13(4), 1991.
#pragma once

#include <string>
#include <vector>

#include "fringe/geometry/rigid3.h"

namespace fringe {

struct RigidAlignment {
  enum class Status { kOk, kTooFewPoints, kDegenerate };
  Status status = Status::kTooFewPoints;
  std::string message;
  Rigid3d b_from_a;   // valid only when status == kOk
  double rms_mm = 0;  // weighted RMS residual |b_from_a * a_i - b_i| after alignment
  int num_points = 0;

  bool ok() const { return status == Status::kOk; }
};

// Finds b_from_a minimising sum_i w_i |b_from_a * p_in_a[i] - p_in_b[i]|^2. `weights` is empty
// (all 1) or one non-negative weight per pair. Returns kTooFewPoints with fewer than 3 pairs of
// positive weight and kDegenerate when the points are (nearly) collinear, where the rotation
// about their line is undetermined. Throws fringe::Error on size mismatch or negative weight.
RigidAlignment AlignRigid(const std::vector<Eigen::Vector3d>& p_in_a,
                          const std::vector<Eigen::Vector3d>& p_in_b,
                          const std::vector<double>& weights = {});

}  // namespace fringe
