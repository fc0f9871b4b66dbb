// Geometry of a planar calibration target (board), shared by the simulator (which renders it)
// and calibration (which detects it). Board frame: origin at the centre of feature (row 0,
// col 0), x along columns, y along rows, z = 0 on the printed surface, normal -z toward the
// cameras when the board faces them; millimetres.
#pragma once

#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

namespace fringe {

enum class TargetType {
  kConcentricRings,       // dark annulus (outer/inner radius) per feature on white
  kCircleGrid,            // solid dark circles (radius = outer_radius_mm), symmetric grid
  kAsymmetricCircleGrid,  // rows spacing apart, odd rows shifted by spacing/2 (NOT OpenCV's
                          // layout, whose rows are spacing/2 apart)
  kChessboard,            // rows x cols INNER corners, square size = spacing_mm
};

const char* TargetTypeName(TargetType t);
// Throws fringe::Error for an unknown name ("rings", "circles", "asymmetric_circles",
// "chessboard").
TargetType TargetTypeFromName(const std::string& name);

struct CalibrationTarget {
  TargetType type = TargetType::kConcentricRings;
  int rows = 7;                  // feature rows (chessboard: inner-corner rows), >= 2
  int cols = 9;                  // feature columns, >= 2
  double spacing_mm = 24.0;      // centre-to-centre spacing (chessboard: square size), > 0
  double outer_radius_mm = 8.0;  // rings: outer radius of the dark annulus; circles: radius
  double inner_radius_mm = 4.5;  // rings: inner (white) radius, 0 < inner < outer
  // Rings only: these features (row, col) carry an extra dark centre dot of this radius, so the
  // grid's orientation and origin are unambiguous even on partial views. The default L of three
  // features near the middle is asymmetric under every grid symmetry.
  double dot_radius_mm = 1.6;  // < inner_radius_mm
  std::vector<std::pair<int, int>> distinct_features = {{3, 4}, {3, 5}, {2, 4}};
  double margin_mm = 6.0;  // white border around the outermost features

  // The reference board of ../shared/SPEC.md: 7 x 9 concentric rings at 24 mm, about
  // 220 x 180 mm printed.
  static CalibrationTarget Reference() { return CalibrationTarget(); }

  void Check() const;
  int NumFeatures() const { return rows * cols; }
  // Feature centre in the board frame (z = 0).
  Eigen::Vector3d FeatureCentre(int row, int col) const;
  // All centres, row-major (index = row * cols + col).
  std::vector<Eigen::Vector3d> FeatureCentres() const;
  bool IsDistinct(int row, int col) const;
  // Printed board extent in the board frame: [min, max] corners (z = 0).
  void Extent(Eigen::Vector2d* min, Eigen::Vector2d* max) const;
};

}  // namespace fringe
