#include "fringe/geometry/calibration_target.h"

#include <gtest/gtest.h>

#include "fringe/util/error.h"

namespace fringe {
namespace {

TEST(CalibrationTarget, ReferenceIsAbout220By180) {
  const CalibrationTarget t = CalibrationTarget::Reference();
  EXPECT_NO_THROW(t.Check());
  Eigen::Vector2d lo, hi;
  t.Extent(&lo, &hi);
  EXPECT_NEAR(hi.x() - lo.x(), 220, 10);
  EXPECT_NEAR(hi.y() - lo.y(), 180, 10);
  EXPECT_EQ(t.FeatureCentres().size(), 63u);
  EXPECT_TRUE(t.IsDistinct(3, 4));
  EXPECT_FALSE(t.IsDistinct(0, 0));
}

TEST(CalibrationTarget, AsymmetricRowsShift) {
  CalibrationTarget t;
  t.type = TargetType::kAsymmetricCircleGrid;
  EXPECT_DOUBLE_EQ(t.FeatureCentre(1, 0).x(), 0.5 * t.spacing_mm);
  EXPECT_DOUBLE_EQ(t.FeatureCentre(2, 0).x(), 0.0);
}

TEST(CalibrationTarget, CheckNamesField) {
  CalibrationTarget t;
  t.inner_radius_mm = 9;
  EXPECT_THROW(t.Check(), Error);
  EXPECT_THROW(TargetTypeFromName("hexagons"), Error);
  EXPECT_EQ(TargetTypeFromName("chessboard"), TargetType::kChessboard);
}

}  // namespace
}  // namespace fringe
