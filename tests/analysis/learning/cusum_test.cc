#include "analysis/learning/cusum.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis::learning {
namespace {

using ::testing::HasSubstr;

// Worked by hand (docs/analysis.md, "CUSUM learning curve"), p0 = 0.1,
// p1 = 0.3, alpha = 0.05, beta = 0.2:
//   P = ln(0.3/0.1) = 1.098612, Q = ln(0.9/0.7) = 0.251314, P + Q = 1.349927
//   s  = Q / (P + Q)              = 0.186169
//   h1 = ln(0.8/0.05) / (P + Q)   = 2.772589 / 1.349927 = 2.053881
//   h0 = ln(0.95/0.2) / (P + Q)   = 1.558145 / 1.349927 = 1.154244
// Sequence F F S F F S S ... S (20 trials):
//   trial 1 F: 0 + 0.813831 = 0.813831
//   trial 2 F: 1.627662
//   trial 3 S: 1.627662 - 0.186169 = 1.441493
//   trial 4 F: 1.441493 + 0.813831 = 2.255324 >= h1 (first crossing: 4)
//   trial 5 F: 3.069155; then 15 successes: 3.069155 - 15 s = 0.276621
// LC-CUSUM (success + Q, failure - P, floored at 0): 0, 0, 0.251314, 0, 0,
// then + Q per success: trial 13 = 8 Q = 2.010515, the first >= h_lc = 2.
// All successes: score -t s <= -h0 first at t = 7 (-1.303183; t = 6 gives
// -1.117014).
TEST(Cusum, HandWorkedSequence) {
  CusumSpec spec{0.1, 0.3, 0.05, 0.2, 2.0};
  std::vector<bool> f(20, false);
  f[0] = f[1] = f[3] = f[4] = true;
  const CusumChart c = cusum_chart(f, spec);
  EXPECT_NEAR(c.s, 0.186169, 1e-6);
  EXPECT_NEAR(c.h1, 2.053881, 1e-6);
  EXPECT_NEAR(c.h0, 1.154244, 1e-6);
  ASSERT_EQ(c.score.size(), 20u);
  EXPECT_NEAR(c.score[0], 0.813831, 1e-6);
  EXPECT_NEAR(c.score[2], 1.441493, 1e-6);
  EXPECT_NEAR(c.score[3], 2.255324, 1e-6);
  EXPECT_NEAR(c.score[4], 3.069155, 1e-6);
  EXPECT_NEAR(c.score[19], 0.276621, 1e-6);
  EXPECT_EQ(c.first_above_h1, 4u);
  EXPECT_FALSE(c.first_below_h0);
  EXPECT_NEAR(c.lc_score[2], 0.251314, 1e-6);
  EXPECT_EQ(c.lc_score[4], 0.0);
  EXPECT_NEAR(c.lc_score[12], 2.010515, 1e-6);
  EXPECT_EQ(c.lc_proficient_at, 13u);

  const CusumChart good = cusum_chart(std::vector<bool>(10, false), spec);
  EXPECT_NEAR(good.score[5], -1.117014, 1e-6);
  EXPECT_EQ(good.first_below_h0, 7u);
  EXPECT_FALSE(good.first_above_h1);
}

TEST(Cusum, FailuresAgainstCriterion) {
  EXPECT_EQ(failures_against({30, 20, 25}, 25, false), (std::vector<bool>{true, false, false}));
  EXPECT_EQ(failures_against({0.7, 0.9}, 0.8, true), (std::vector<bool>{true, false}));
  EXPECT_THROW(failures_against({1.0, NAN}, 1.0, false), DataError);
}

TEST(Cusum, RefusesBadSpecificationByName) {
  auto message = [](CusumSpec spec) {
    try {
      cusum_chart({true}, spec);
    } catch (const DataError& e) {
      return std::string(e.what());
    }
    return std::string("no refusal");
  };
  EXPECT_THAT(message({0.2, 0.2, 0.05, 0.2, {}}), HasSubstr("p1 = 0.2 is refused (allowed: p1 > p0 = 0.2"));
  EXPECT_THAT(message({0.3, 0.1, 0.05, 0.2, {}}), HasSubstr("p1 = 0.1 is refused"));
  EXPECT_THAT(message({0.0, 0.3, 0.05, 0.2, {}}), HasSubstr("p0 = 0 is refused (allowed: 0 < p0 < 1)"));
  EXPECT_THAT(message({0.1, 0.3, 0.5, 0.2, {}}), HasSubstr("alpha = 0.5 is refused"));
  EXPECT_THAT(message({0.1, 0.3, 0.05, 0.0, {}}), HasSubstr("beta = 0 is refused"));
  EXPECT_THAT(message({0.1, 0.3, 0.05, 0.2, -1.0}), HasSubstr("lc_limit = -1 is refused"));
}

}  // namespace
}  // namespace hapticlab::analysis::learning
