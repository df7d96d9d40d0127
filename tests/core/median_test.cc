#include "engine/core/median.h"

#include <gtest/gtest.h>

namespace glam {
namespace {

TEST(UpperMedian, IsTheMiddleValueOrTheUpperOfTheTwoMiddleOnes) {
  EXPECT_EQ(UpperMedian({5.0, 1.0, 3.0}), 3.0);
  EXPECT_EQ(UpperMedian({4.0, 1.0, 3.0, 2.0}), 3.0);  // never the mean 2.5
  EXPECT_EQ(UpperMedian({7.0}), 7.0);
  EXPECT_EQ(UpperMedian({}), 0.0);
}

}  // namespace
}  // namespace glam
