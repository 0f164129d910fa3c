#include "analysis/stats/wilson.h"

#include <gtest/gtest.h>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {
namespace {

// By hand, z = 1.959964 (two-sided 95 %), z^2 = 3.841459:
//   5 of 10: centre (0.5 + z^2/20) / (1 + z^2/10) = 0.5; half-width
//     z / (1 + z^2/10) * sqrt(0.25/10 + z^2/400) = 1.416009 * 0.186020 = 0.263407.
//   0 of 20: centre = half-width = (z^2/40) / (1 + z^2/20) = 0.080563; so [0, 0.161126]
//     (the Wald interval would be [0, 0]).
TEST(WilsonIntervalTest, HandWorkedValues) {
  const ProportionInterval half = wilson_interval(5, 10);
  EXPECT_NEAR(half.low, 0.236593, 1e-6);
  EXPECT_NEAR(half.high, 0.763407, 1e-6);
  const ProportionInterval none = wilson_interval(0, 20);
  EXPECT_EQ(none.low, 0.0);
  EXPECT_NEAR(none.high, 0.161126, 1e-6);
  const ProportionInterval all = wilson_interval(20, 20);  // the mirror image
  EXPECT_NEAR(all.low, 1.0 - 0.161126, 1e-6);
  EXPECT_EQ(all.high, 1.0);
}

TEST(WilsonIntervalTest, BadInputIsRefused) {
  EXPECT_THROW(wilson_interval(0, 0), DataError);
  EXPECT_THROW(wilson_interval(3, 2), DataError);
  EXPECT_THROW(wilson_interval(1, 2, 1.0), DataError);
}

}  // namespace
}  // namespace hapticlab::analysis
