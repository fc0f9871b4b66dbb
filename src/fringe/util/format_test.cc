#include "fringe/util/format.h"

#include <gtest/gtest.h>

#include <limits>

namespace fringe::util {
namespace {

TEST(Fixed, WritesTheGivenDigitsAfterThePoint) {
  EXPECT_EQ(Fixed(0.0678, 3), "0.068");
  EXPECT_EQ(Fixed(-1.5, 0), "-2");
  EXPECT_EQ(Fixed(2, 2), "2.00");
}

TEST(FigureOrNull, FiniteIsANumberElseNull) {
  EXPECT_TRUE(FigureOrNull(0.25).is_number_float());
  EXPECT_EQ(FigureOrNull(0.25).get<double>(), 0.25);
  EXPECT_TRUE(FigureOrNull(std::numeric_limits<double>::quiet_NaN()).is_null());
  EXPECT_TRUE(FigureOrNull(std::numeric_limits<double>::infinity()).is_null());
}

}  // namespace
}  // namespace fringe::util
