#include "analysis/report/box_stats.h"

#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {
namespace {

constexpr double kTolerance = 1e-12;

// By hand, MATLAB percentiles of 1..8 and 100 (n = 9, x(i) at 100(i − 0.5)/9):
// q1 at position 9·0.25 + 0.5 = 2.75 -> 2.75; median x(5) = 5; q3 at 7.25 ->
// 7.25. IQR 4.5; 3·IQR reaches 2.75 − 13.5 and 7.25 + 13.5 = 20.75, so 100
// is an outlier, the upper whisker stops at 8 and the lower at 1.
TEST(BoxStatsTest, ThreeIqrWhiskersByHand) {
  const std::vector<double> v = {100, 1, 2, 3, 4, 5, 6, 7, 8};
  const BoxStats b = box_stats(v);
  EXPECT_EQ(b.n, 9u);
  EXPECT_NEAR(b.q1, 2.75, kTolerance);
  EXPECT_NEAR(b.median, 5.0, kTolerance);
  EXPECT_NEAR(b.q3, 7.25, kTolerance);
  EXPECT_DOUBLE_EQ(b.whisker_low, 1.0);
  EXPECT_DOUBLE_EQ(b.whisker_high, 8.0);
  EXPECT_EQ(b.outliers, (std::vector<double>{100}));
}

// With the usual 1.5 × IQR, 100 is still out, and with 30 × IQR (reach 135)
// nothing is.
TEST(BoxStatsTest, WhiskerReachIsAParameter) {
  const std::vector<double> v = {100, 1, 2, 3, 4, 5, 6, 7, 8};
  EXPECT_TRUE(box_stats(v, 30.0).outliers.empty());
  EXPECT_DOUBLE_EQ(box_stats(v, 30.0).whisker_high, 100.0);
}

TEST(BoxStatsTest, BadInput) {
  EXPECT_THROW(box_stats(std::vector<double>{}), DataError);
  EXPECT_THROW(box_stats(std::vector<double>{1, 2}, -1.0), DataError);
}

}  // namespace
}  // namespace hapticlab::analysis
