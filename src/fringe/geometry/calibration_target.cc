#include "fringe/geometry/calibration_target.h"

#include <algorithm>

#include "fringe/util/error.h"

namespace fringe {

const char* TargetTypeName(TargetType t) {
  switch (t) {
    case TargetType::kConcentricRings:
      return "rings";
    case TargetType::kCircleGrid:
      return "circles";
    case TargetType::kAsymmetricCircleGrid:
      return "asymmetric_circles";
    case TargetType::kChessboard:
      return "chessboard";
  }
  return "?";
}

TargetType TargetTypeFromName(const std::string& name) {
  for (TargetType t : {TargetType::kConcentricRings, TargetType::kCircleGrid,
                       TargetType::kAsymmetricCircleGrid, TargetType::kChessboard}) {
    if (name == TargetTypeName(t)) return t;
  }
  throw Error(util::StrCat("unknown target type '", name,
                           "' (expected rings, circles, asymmetric_circles or chessboard)"));
}

void CalibrationTarget::Check() const {
  using util::CheckOption;
  CheckOption(rows >= 2, "CalibrationTarget", "rows", rows, "must be >= 2");
  CheckOption(cols >= 2, "CalibrationTarget", "cols", cols, "must be >= 2");
  // Printed boards are millimetres to metres across: 10 m bounds a unit mistake or a hostile file.
  constexpr double kMaxLengthMm = 10000;
  CheckOption(spacing_mm > 0 && spacing_mm <= kMaxLengthMm, "CalibrationTarget", "spacing_mm",
              spacing_mm, "must be in (0, 10000]");
  if (type != TargetType::kChessboard) {
    CheckOption(outer_radius_mm > 0 && 2 * outer_radius_mm < spacing_mm, "CalibrationTarget",
                "outer_radius_mm", outer_radius_mm, "must be > 0 and < spacing_mm / 2");
  }
  if (type == TargetType::kConcentricRings) {
    CheckOption(inner_radius_mm > 0 && inner_radius_mm < outer_radius_mm, "CalibrationTarget",
                "inner_radius_mm", inner_radius_mm, "must be > 0 and < outer_radius_mm");
    CheckOption(dot_radius_mm >= 0 && dot_radius_mm < inner_radius_mm, "CalibrationTarget",
                "dot_radius_mm", dot_radius_mm, "must be >= 0 and < inner_radius_mm");
    for (const auto& [r, c] : distinct_features) {
      CheckOption(r >= 0 && r < rows && c >= 0 && c < cols, "CalibrationTarget",
                  "distinct_features", util::StrCat("(", r, ", ", c, ")"), "outside the grid");
    }
  }
  CheckOption(margin_mm >= 0 && margin_mm <= kMaxLengthMm, "CalibrationTarget", "margin_mm",
              margin_mm, "must be in [0, 10000]");
}

Eigen::Vector3d CalibrationTarget::FeatureCentre(int row, int col) const {
  double x = col * spacing_mm;
  if (type == TargetType::kAsymmetricCircleGrid && (row % 2 == 1)) x += 0.5 * spacing_mm;
  return {x, row * spacing_mm, 0.0};
}

std::vector<Eigen::Vector3d> CalibrationTarget::FeatureCentres() const {
  std::vector<Eigen::Vector3d> out;
  out.reserve(NumFeatures());
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) out.push_back(FeatureCentre(r, c));
  }
  return out;
}

bool CalibrationTarget::IsDistinct(int row, int col) const {
  return type == TargetType::kConcentricRings &&
         std::find(distinct_features.begin(), distinct_features.end(), std::make_pair(row, col)) !=
             distinct_features.end();
}

void CalibrationTarget::Extent(Eigen::Vector2d* min, Eigen::Vector2d* max) const {
  // Chessboards: the outer squares extend one square beyond the inner corners.
  const double pad =
      type == TargetType::kChessboard ? spacing_mm + margin_mm : outer_radius_mm + margin_mm;
  double x_max = (cols - 1) * spacing_mm;
  if (type == TargetType::kAsymmetricCircleGrid) x_max += 0.5 * spacing_mm;
  *min = Eigen::Vector2d(-pad, -pad);
  *max = Eigen::Vector2d(x_max + pad, (rows - 1) * spacing_mm + pad);
}

}  // namespace fringe
