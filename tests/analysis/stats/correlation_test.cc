#include "analysis/stats/correlation.h"

#include <cmath>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {
namespace {

using ::testing::HasSubstr;

// R's cor.test(x, y) output, as published in the articles cited per test;
// tolerances are half a unit in the last printed digit.

// datasciencetut.com / R-bloggers "Correlation Coefficient p value in R":
//   t = -3.0109, df = 8, p-value = 0.01679, cor -0.7288512
TEST(CorrelationTest, StrongNegativeMatchesR) {
  const std::vector<double> x = {710, 718, 920, 187, 884, 486, 491, 174, 283, 585};
  const std::vector<double> y = {590, 494, 679, 886, 484, 853, 808, 992, 756, 975};
  const CorrelationResult c = pearson_correlation(x, y);
  EXPECT_NEAR(c.r, -0.7288512, 5e-8);
  EXPECT_NEAR(c.t, -3.0109, 5e-5);
  EXPECT_EQ(c.df, 8.0);
  EXPECT_NEAR(c.p, 0.01679, 5e-6);
  EXPECT_EQ(c.n, 10u);
  EXPECT_EQ(c.strength, CorrelationStrength::kStrong);
}

// R-bloggers "Parametric method for the study of the correlation" (2009):
//   t = 0.4772, df = 8, p-value = 0.646, cor 0.166349
TEST(CorrelationTest, NoCorrelationMatchesR) {
  const std::vector<double> a = {15, 21, 25, 26, 30, 30, 22, 29, 19, 16};
  const std::vector<double> b = {55, 56, 89, 67, 84, 89, 99, 62, 83, 88};
  const CorrelationResult c = pearson_correlation(a, b);
  EXPECT_NEAR(c.r, 0.166349, 5e-7);
  EXPECT_NEAR(c.t, 0.4772, 5e-5);
  EXPECT_NEAR(c.p, 0.646, 5e-4);
  EXPECT_EQ(c.strength, CorrelationStrength::kNone);
}

// Thesis 3.4.2.2: |R| < 0.3 none, 0.3 <= |R| < 0.7 weak, |R| >= 0.7 strong;
// Table 3.7's -0.51 and 0.61 are weak, 3.4.2.2's 0.74 and -0.71 strong.
TEST(CorrelationTest, ThesisClassification) {
  EXPECT_EQ(classify_correlation(0.7), CorrelationStrength::kStrong);
  EXPECT_EQ(classify_correlation(-0.71), CorrelationStrength::kStrong);
  EXPECT_EQ(classify_correlation(0.74), CorrelationStrength::kStrong);
  EXPECT_EQ(classify_correlation(0.6999), CorrelationStrength::kWeak);
  EXPECT_EQ(classify_correlation(-0.51), CorrelationStrength::kWeak);
  EXPECT_EQ(classify_correlation(0.61), CorrelationStrength::kWeak);
  EXPECT_EQ(classify_correlation(0.3), CorrelationStrength::kWeak);
  EXPECT_EQ(classify_correlation(-0.2999), CorrelationStrength::kNone);
  EXPECT_EQ(correlation_strength_name(CorrelationStrength::kWeak), "weak");
}

TEST(CorrelationTest, PerfectLineHasZeroP) {
  const std::vector<double> x = {1, 2, 3, 4};
  const std::vector<double> y = {-2, -4, -6, -8};
  const CorrelationResult c = pearson_correlation(x, y);
  EXPECT_DOUBLE_EQ(c.r, -1.0);
  EXPECT_TRUE(std::isinf(c.t));
  EXPECT_EQ(c.p, 0.0);
}

TEST(CorrelationTest, RejectsBadInput) {
  const std::vector<double> three = {1, 2, 3};
  EXPECT_THROW(pearson_correlation(three, std::vector<double>{1, 2}), DataError);
  EXPECT_THROW(pearson_correlation(std::vector<double>{1, 2}, std::vector<double>{1, 2}),
               DataError);
  EXPECT_THROW(pearson_correlation(three, std::vector<double>{5, 5, 5}), DataError);
  EXPECT_THROW(pearson_correlation(three, std::vector<double>{1, NAN, 2}), DataError);
}

// 0.1 + 0.1 + 0.1 = 0.30000000000000004, so the mean of three 0.1s is
// 0.10000000000000002 and Σ(y − ȳ)² = 6e-34, not 0: without a tolerance this
// gave r = 0, p = 1 for a constant y.
TEST(CorrelationTest, ConstantUpToRoundingIsRefused) {
  const std::vector<double> x = {1, 2, 3};
  const std::vector<double> y = {0.1, 0.1, 0.1};
  try {
    pearson_correlation(x, y, "trial", "force_N");
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("force_N is constant"));
    EXPECT_THAT(e.what(), HasSubstr("0.1"));
  }
  EXPECT_THROW(pearson_correlation(y, x), DataError);
  // A real spread, 7000 ulps of 0.1 and some 200 times the threshold, is
  // still a correlation (the steps are exact to 1 ulp in 7000).
  const CorrelationResult tiny =
      pearson_correlation(x, std::vector<double>{0.1, 0.1 + 1e-13, 0.1 + 2e-13});
  EXPECT_NEAR(tiny.r, 1.0, 1e-3);
}

// r does not depend on the units, but the squares of deviations overflow
// beyond about 1e154 and underflow below about 1e-154: values of 1e155 gave
// r = 0, p = 1, values of 1e-200 "constant". Worked: r of {1, 2, 3, 4} and
// {1, 2, 1.5, 4} is 4.25 / sqrt(5 * 5.1875) = 0.834497 (scipy's pearsonr
// agrees), at any scale; a constant at 1e-200 is still refused.
TEST(CorrelationTest, ValuesNearTheEndsOfTheDoubleRangeGiveTheSameR) {
  const std::vector<double> x = {1, 2, 3, 4};
  const std::vector<double> y = {1, 2, 1.5, 4};
  const double r = 4.25 / std::sqrt(5.0 * 5.1875);
  EXPECT_NEAR(pearson_correlation(x, y).r, r, 1e-15);
  for (const double scale : {1e155, 1e300, 1e-200, 1e-300}) {
    std::vector<double> big = y;
    for (double& v : big) v *= scale;
    EXPECT_NEAR(pearson_correlation(x, big).r, r, 1e-14) << scale;
    EXPECT_NEAR(pearson_correlation(big, x).r, r, 1e-14) << scale;
  }
  EXPECT_THROW(pearson_correlation(x, std::vector<double>(4, 1e-200)), DataError);
}

}  // namespace
}  // namespace hapticlab::analysis
