#include "analysis/stats/sign_flip.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {
namespace {

// By hand. {1, 2, 3}: the 8 sign patterns sum to ±6, ±4, ±2, 0, 0; only
// ±6 reach |6|: p = 2/8. {2, 3, 5, 7}: 16 patterns, only ±17 reach 17:
// p = 2/16. {1, -1}: observed 0, every pattern reaches it: p = 1.
// {1, 1, 1}: ±3 of 8 -> 0.25 (ties of equal values are no problem).
TEST(SignFlipTest, HandWorkedExactValues) {
  EXPECT_DOUBLE_EQ(sign_flip_test(std::vector<double>{1, 2, 3}).p, 0.25);
  EXPECT_DOUBLE_EQ(sign_flip_test(std::vector<double>{2, 3, 5, 7}).p, 0.125);
  EXPECT_DOUBLE_EQ(sign_flip_test(std::vector<double>{1, -1}).p, 1.0);
  EXPECT_DOUBLE_EQ(sign_flip_test(std::vector<double>{1, 1, 1}).p, 0.25);
  // {4, -1, 2}: sums 5 (observed), -3, 1, 7, 3, -7, -1, -5 for the other
  // patterns; |sum| >= 5: 5, 7, -7, -5 -> 4/8.
  const SignFlipResult r = sign_flip_test(std::vector<double>{4, -1, 2});
  EXPECT_DOUBLE_EQ(r.p, 0.5);
  EXPECT_DOUBLE_EQ(r.mean, 5.0 / 3.0);
  EXPECT_TRUE(r.exact);
}

// Sums that equal the observed one in another order of addition count.
TEST(SignFlipTest, RoundingDoesNotBreakTies) {
  EXPECT_DOUBLE_EQ(sign_flip_test(std::vector<double>{0.1, 0.2, 0.3}).p, 0.25);
}

// 25 equal positive differences: only the all-plus and all-minus patterns
// reach the observed sum, so p = 2/2^25 exactly; the Monte Carlo estimate
// with the observed pattern counted is (k + 1)/(2^20 + 1) with k ~ 0.
TEST(SignFlipTest, MonteCarloBeyondTwentyFour) {
  const SignFlipResult r = sign_flip_test(std::vector<double>(25, 1.0));
  EXPECT_FALSE(r.exact);
  EXPECT_LT(r.p, 5.0 / ((1 << 20) + 1.0));
}

TEST(SignFlipTest, BadInputIsRefused) {
  EXPECT_THROW(sign_flip_test(std::vector<double>{}), DataError);
  EXPECT_THROW(sign_flip_test(std::vector<double>{1.0, std::nan("")}), DataError);
}

}  // namespace
}  // namespace hapticlab::analysis
