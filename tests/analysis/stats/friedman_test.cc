#include "analysis/stats/friedman.h"

#include <cmath>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/stats/data_error.h"
#include "analysis/stats/testing_tables.h"

namespace hapticlab::analysis {
namespace {

using ::testing::HasSubstr;

// R prints the statistic to 5 significant digits and p to 4: half a unit in
// the last printed digit.
constexpr double kRStatisticTolerance = 0.0005;
constexpr double kRPTolerance = 0.0000005;
// Exact rational statistics: only rounding error.
constexpr double kExactTolerance = 1e-12;

// R: friedman.test(RoundingTimes)
//   Friedman chi-squared = 11.143, df = 2, p-value = 0.003805
// The data has ties (e.g. player 7: 5.40, 5.40, 5.35), so this checks the tie
// correction too (without it the statistic is 10.636, not 11.143).
TEST(FriedmanTest, RoundingTimesMatchesR) {
  const TestResult r = friedman_test(BlockTable::from_matrix(testing::rounding_times()));
  EXPECT_NEAR(r.statistic, 11.143, kRStatisticTolerance);
  EXPECT_EQ(r.df, 2.0);
  EXPECT_NEAR(r.p, 0.003805, kRPTolerance);
  EXPECT_EQ(r.blocks, 22u);
  EXPECT_EQ(r.treatments, 3u);
  EXPECT_EQ(r.observations, 66u);
}

// scipy: friedmanchisquare(before, immediately_after, five_min_after), the
// pulse rates of 7 students (Sprent & Smeeton 6.3.2, scipy's documentation):
//   statistic 10.57142857142857, pvalue 0.005063414171757498
// No ties, so the statistic is the rational 74/7; p from chi-square df 2 is
// exp(-37/7), which Boost must give to a few ulps.
TEST(FriedmanTest, PulseRatesMatchScipy) {
  const std::vector<std::vector<double>> pulse = {
      {72, 120, 76}, {96, 120, 95}, {88, 132, 104}, {92, 120, 96},
      {74, 101, 84}, {76, 96, 72},  {82, 112, 76}};
  const TestResult r = friedman_test(BlockTable::from_matrix(pulse));
  EXPECT_NEAR(r.statistic, 10.57142857142857, kExactTolerance);
  EXPECT_EQ(r.df, 2.0);
  EXPECT_NEAR(r.p, 0.005063414171757498, 1e-15);
  EXPECT_EQ(r.blocks, 7u);
  EXPECT_EQ(r.observations, 21u);
}

// Hand-worked, 3 blocks × 3 treatments with ties:
//   block 1: 1, 2, 3  -> ranks 1,   2,   3
//   block 2: 2, 2, 5  -> ranks 1.5, 1.5, 3     (one pair tied: 2³−2 = 6)
//   block 3: 4, 1, 1  -> ranks 3,   1.5, 1.5   (one pair tied: 6)
//   R = (5.5, 5, 7.5), expected b(k+1)/2 = 6, Σ(R − 6)² = 0.25 + 1 + 2.25 = 3.5
//   uncorrected 12·3.5/(b·k·(k+1)) = 42/36 = 1.1667
//   tie-corrected 12·3.5/(b·k·(k+1) − Σ(t³−t)/(k−1)) = 42/(36 − 12/2) = 1.4
//   df = 2, so p = exp(−1.4/2) = exp(−0.7)
TEST(FriedmanTest, HandWorkedTies) {
  const TestResult r =
      friedman_test(BlockTable::from_matrix({{1, 2, 3}, {2, 2, 5}, {4, 1, 1}}));
  EXPECT_NEAR(r.statistic, 1.4, kExactTolerance);
  EXPECT_NEAR(r.p, std::exp(-0.7), kExactTolerance);
}

// MATLAB: friedman(popcorn, 3) -> Columns Chi-sq 13.76, df 2, p = 0.0010
// (MATLAB documentation example; exact values 13.75862068965517 and
// 0.001028853354594794 as recorded from MATLAB in GNU Octave statistics'
// friedman.m tests). By hand, ranking each popper's 9 values together:
//   oil: brand rank sums 24, 14.5, 6.5 (three tied pairs:  Σ(t³−t) = 18)
//   air: brand rank sums 24, 14,   7   (a triple and a pair: Σ(t³−t) = 30)
//   R = (48, 28.5, 13.5), E = b·r·(N+1)/2 = 30, Σ(R − E)² = 598.5
//   σ² = N(N+1)/12 − 48/(12·b·(N−1)) = 7.5 − 0.25 = 7.25
//   Q = 598.5/(b·r·σ²) = 598.5/43.5 = 13.758620689655...
TEST(FriedmanTest, ReplicatesMatchMatlabPopcorn) {
  const TestResult r = friedman_test(BlockTable::from_matrix(testing::popcorn(), 3));
  EXPECT_NEAR(r.statistic, 598.5 / 43.5, kExactTolerance);
  EXPECT_NEAR(r.statistic, 13.75862068965517, kExactTolerance);
  EXPECT_NEAR(r.p, 0.001028853354594794, 1e-15);
  EXPECT_EQ(r.df, 2.0);
  EXPECT_EQ(r.blocks, 2u);
  EXPECT_EQ(r.observations, 18u);
}

// The same data in long format, rows in any order, names instead of indices.
TEST(FriedmanTest, LongFormatGivesTheSameResult) {
  const auto rows = testing::popcorn();
  const char* brands[] = {"gourmet", "national", "generic"};
  std::vector<Observation> obs;
  for (std::size_t c = 3; c-- > 0;) {
    for (std::size_t r = 0; r < rows.size(); ++r) {
      obs.push_back({r < 3 ? "oil" : "air", brands[c], std::to_string(r % 3), rows[r][c]});
    }
  }
  const TestResult r = friedman_test(BlockTable::from_observations(obs));
  EXPECT_NEAR(r.statistic, 13.75862068965517, kExactTolerance);
}

TEST(FriedmanTest, AllTiedBlocksGiveZero) {
  const TestResult r = friedman_test(BlockTable::from_matrix({{1, 1}, {2, 2}}));
  EXPECT_EQ(r.statistic, 0.0);
  EXPECT_EQ(r.p, 1.0);
}

TEST(FriedmanTest, MissingCellIsRejectedWithItsName) {
  const std::vector<Observation> obs = {
      {"S1", "HiFi", "", 1.0}, {"S1", "NoFFB", "", 2.0}, {"S2", "HiFi", "", 1.5}};
  try {
    friedman_test(BlockTable::from_observations(obs));
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("'S2'"));
    EXPECT_THAT(e.what(), HasSubstr("'NoFFB'"));
    EXPECT_THAT(e.what(), HasSubstr("Skillings-Mack"));
  }
}

TEST(FriedmanTest, UnequalReplicatesAreRejected) {
  const std::vector<Observation> obs = {{"S1", "A", "", 1.0}, {"S1", "A", "", 1.2},
                                        {"S1", "B", "", 2.0}, {"S2", "A", "", 1.5},
                                        {"S2", "B", "", 2.5}, {"S2", "B", "", 2.6}};
  try {
    friedman_test(BlockTable::from_observations(obs));
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("same number of replicates"));
  }
}

TEST(FriedmanTest, OneTreatmentIsRejected) {
  EXPECT_THROW(friedman_test(BlockTable::from_matrix({{1}, {2}})), DataError);
}

}  // namespace
}  // namespace hapticlab::analysis
