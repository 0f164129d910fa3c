#include "analysis/stats/effect_size.h"

#include <limits>

#include <gtest/gtest.h>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {
namespace {

// Exact small-number arithmetic: a few ulps at most.
constexpr double kTol = 1e-12;

// 4 blocks ranking 3 settings (1,2,3), (1,3,2), (2,1,3), (1,2,3): rank sums
// 5, 8, 11. Friedman chi2 = 12/(b k (k+1)) sum R^2 - 3 b (k+1)
// = 12/48 * 210 - 48 = 4.5, so W = 4.5 / (4 * 2) = 0.5625; by the definition
// W = 12 S / (b^2 (k^3 - k)) with S = 9 + 0 + 9 = 18: 216 / 384 = 0.5625.
TEST(EffectSizeTest, KendallsWFromFriedmanHandWorked) {
  EXPECT_NEAR(kendalls_w(4.5, 4, 3), 0.5625, kTol);
  // 3 blocks in full agreement: chi2 = 6 = b (k - 1), W = 1.
  EXPECT_NEAR(kendalls_w(6.0, 3, 3), 1.0, kTol);
  EXPECT_NEAR(kendalls_w(0.0, 5, 4), 0.0, kTol);
  // Replicates (MATLAB friedman(X, reps)): 1 block, k = 2 settings, r = 2
  // replicates, values A = {1, 2}, B = {3, 4}: ranks A 1, 2, B 3, 4; rank sums
  // 3 and 7, E = b r (n + 1)/2 = 5, sum of squares 8; sigma^2 = n (n + 1)/12
  // = 20/12; Q = 8 / (b r sigma^2) = 2.4 — the largest possible, so W = 1:
  // Q_max = b r^2 (k^2 - 1)/(r k + 1) = 4 * 3 / 5 = 2.4.
  EXPECT_NEAR(kendalls_w(2.4, 1, 2, 2), 1.0, kTol);
  EXPECT_NEAR(kendalls_w(1.2, 1, 2, 2), 0.5, kTol);
  EXPECT_THROW((void)kendalls_w(1.0, 4, 1), DataError);
  EXPECT_THROW((void)kendalls_w(1.0, 4, 3, 0), DataError);
  EXPECT_THROW((void)kendalls_w(1.0, 0, 3), DataError);
}

// d = 3, -1, 2, 5, 0: the 0 is dropped; |d| ranks 3, 1, 2, 4; T+ = 9,
// T- = 1; r = 8 / 10.
TEST(EffectSizeTest, RankBiserialHandWorked) {
  EXPECT_NEAR(matched_pairs_rank_biserial({3, -1, 2, 5, 0}), 0.8, kTol);
  // Ties share ranks: |d| = 1, 1, 2 rank 1.5, 1.5, 3; T+ = 4.5, T- = 1.5.
  EXPECT_NEAR(matched_pairs_rank_biserial({1, -1, 2}), 0.5, kTol);
  EXPECT_NEAR(matched_pairs_rank_biserial({-1, -2}), -1.0, kTol);
  EXPECT_NEAR(matched_pairs_rank_biserial({0, 0}), 0.0, kTol);
  EXPECT_THROW((void)matched_pairs_rank_biserial({1, std::numeric_limits<double>::quiet_NaN()}), DataError);
}

// Per block, the treatment's median minus the control's: b1 control {1, 3}
// (median 2), treatment {5}: +3; b2 {2} vs {1}: -1; b3 {0} vs {2}: +2; b4
// has no treatment value and is skipped. |d| ranks 3, 1, 2: T+ = 5, T- = 1,
// r = 4/6.
TEST(EffectSizeTest, PairedRankBiserialOverBlocks) {
  const BlockTable t = BlockTable::from_observations({{"b1", "C", "1", 1}, {"b1", "C", "2", 3}, {"b1", "T", "1", 5},
                                                      {"b2", "C", "1", 2}, {"b2", "T", "1", 1}, {"b3", "C", "1", 0},
                                                      {"b3", "T", "1", 2}, {"b4", "C", "1", 9}});
  EXPECT_NEAR(paired_rank_biserial(t, t.treatment_index("C"), t.treatment_index("T")), 4.0 / 6.0, kTol);
  EXPECT_NEAR(paired_rank_biserial(t, t.treatment_index("T"), t.treatment_index("C")), -4.0 / 6.0, kTol);
}

}  // namespace
}  // namespace hapticlab::analysis
