#include "analysis/stats/pairwise_friedman.h"

#include <cmath>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/stats/balanced_pair.h"
#include "analysis/stats/data_error.h"
#include "analysis/stats/friedman.h"

namespace hapticlab::analysis {
namespace {

using ::testing::HasSubstr;

// Thesis 3.3.7.1: "only P-values lower than (1 − 0.95^(1/7)) = 0.0073 are
// judged significant". 1 − 0.95^(1/7) = 0.0073010...
TEST(PairwiseFriedmanTest, SidakLevelOfTheThesis) {
  EXPECT_NEAR(sidak_level(0.05, 7), 0.0073, 0.00005);
  EXPECT_NEAR(sidak_level(0.05, 7), 1.0 - std::pow(0.95, 1.0 / 7.0), 1e-15);
  EXPECT_NEAR(sidak_level(0.05, 1), 0.05, 1e-15);
  EXPECT_THROW(sidak_level(0.0, 7), DataError);
  EXPECT_THROW(sidak_level(1.0, 7), DataError);
  EXPECT_THROW(sidak_level(0.05, 0), DataError);
}

// A Table 3.3-like design: blocks are surgeon × hand, two repetitions per
// cell; not every surgeon did every setting.
std::vector<Observation> study() {
  std::vector<Observation> obs;
  auto add = [&](const char* block, const char* setting, double a, double b) {
    obs.push_back({block, setting, "1", a});
    obs.push_back({block, setting, "2", b});
  };
  for (const char* hand : {"S1-RH", "S1-LH", "S2-RH", "S2-LH", "S3-RH", "S3-LH"}) {
    add(hand, "HiFi", 1.0, 1.2);
    add(hand, "NoFFB", 2.0, 2.5);   // always above HiFi
    add(hand, "AllDg", 1.1, 0.9);   // interleaved with HiFi
  }
  for (const char* hand : {"S1-RH", "S1-LH", "S2-RH", "S2-LH"}) add(hand, "Cogg", 1.3, 0.8);
  for (const char* hand : {"S3-RH", "S3-LH"}) add(hand, "Bckl", 1.05, 1.3);
  add("S1-RH", "Frict", 5.0, 5.0);  // a single shared block
  return obs;
}

TEST(PairwiseFriedmanTest, UsesTheBlocksHoldingBoth) {
  const BlockTable table = BlockTable::from_observations(study());
  const auto result = pairwise_friedman_vs_control(table, "HiFi", 0.05);
  ASSERT_EQ(result.size(), 5u);  // m = 5 other treatments
  EXPECT_EQ(result[0].treatment, "NoFFB");
  EXPECT_EQ(result[0].n_blocks, 6u);
  EXPECT_EQ(result[2].treatment, "Cogg");
  EXPECT_EQ(result[2].n_blocks, 4u);
  EXPECT_EQ(result[3].treatment, "Bckl");
  EXPECT_EQ(result[3].n_blocks, 2u);

  // Each p is a Friedman test (replicates ranked within block) on exactly
  // those blocks: rebuild the Cogg pair by hand and compare.
  std::vector<Observation> pair;
  for (const auto& o : study()) {
    const bool block_has_cogg = o.block.rfind("S1", 0) == 0 || o.block.rfind("S2", 0) == 0;
    if (block_has_cogg && (o.treatment == "HiFi" || o.treatment == "Cogg")) pair.push_back(o);
  }
  const TestResult direct = friedman_test(BlockTable::from_observations(pair));
  ASSERT_TRUE(result[2].p.has_value());
  EXPECT_DOUBLE_EQ(*result[2].p, direct.p);
  EXPECT_DOUBLE_EQ(*result[2].statistic, direct.statistic);
}

// NoFFB ranks 3 and 4 of 4 in each of 6 blocks: R = (6·3, 6·7) = (18, 42),
// E = b·r·(N+1)/2 = 30, Σ(R−E)² = 288, no ties, N = 4: σ² = 4·5/12 = 5/3,
// Q = 288/(6·2·5/3) = 14.4; chi-square with 1 df: p = erfc(sqrt(14.4/2)) =
// 0.000148 < 1 − 0.95^(1/5) = 0.0102. AllDg (0.9 < 1.0 < 1.1 < 1.2 in each
// block) has R = (36, 24), Q = 72/20 = 3.6, p = erfc(sqrt(1.8)) = 0.058.
TEST(PairwiseFriedmanTest, ClearDifferenceIsSignificant) {
  const auto result =
      pairwise_friedman_vs_control(BlockTable::from_observations(study()), "HiFi", 0.05);
  EXPECT_NEAR(*result[0].statistic, 14.4, 1e-12);
  EXPECT_NEAR(*result[0].p, std::erfc(std::sqrt(7.2)), 1e-15);
  EXPECT_TRUE(result[0].significant);
  EXPECT_NEAR(*result[1].statistic, 3.6, 1e-12);
  EXPECT_NEAR(*result[1].p, std::erfc(std::sqrt(1.8)), 1e-15);
  EXPECT_FALSE(result[1].significant);  // 0.058 > 0.0102
}

TEST(PairwiseFriedmanTest, NoSharedBlockIsNotApplicable) {
  const auto result =
      pairwise_friedman_vs_control(BlockTable::from_observations(study()), "HiFi", 0.05);
  // S1-RH has HiFi too, so make a treatment that never meets the control:
  std::vector<Observation> obs = study();
  obs.push_back({"S9-RH", "Sat", "1", 1.0});
  obs.push_back({"S9-RH", "Sat", "2", 2.0});
  const auto with_sat =
      pairwise_friedman_vs_control(BlockTable::from_observations(obs), "HiFi", 0.05);
  ASSERT_EQ(with_sat.back().treatment, "Sat");
  EXPECT_FALSE(with_sat.back().p.has_value());
  EXPECT_FALSE(with_sat.back().statistic.has_value());
  EXPECT_EQ(with_sat.back().n_blocks, 0u);
  EXPECT_FALSE(with_sat.back().significant);
  EXPECT_EQ(result.size() + 1, with_sat.size());
}

// A short cell (a timed-out repetition) is balanced away, as the study
// analysis does, instead of failing the comparison. Minimum repetitions in
// both cells: B1 3, B2 2, B3 2. r = 3 keeps 2·3·1 = 6 values, r = 2 keeps
// 2·2·3 = 12 of the 16: r = 2, 4 dropped. Kept, every block ranks C (1, 2)
// below T (3, 4): R = (9, 21), E = 15, Σ(R−E)² = 72, σ² = 5/3 (N = 4),
// Q = 72/(3·2·5/3) = 7.2, p = erfc(sqrt(3.6)).
TEST(PairwiseFriedmanTest, UnequalRepetitionsAreBalanced) {
  std::vector<Observation> obs;
  const auto add = [&](const char* block, const char* treatment, std::vector<double> values) {
    for (double v : values) obs.push_back({block, treatment, "", v});
  };
  add("B1", "C", {1, 2, 3});
  add("B1", "T", {4, 5, 6});
  add("B2", "C", {1, 2, 3});
  add("B2", "T", {4, 5});
  add("B3", "C", {1, 2});
  add("B3", "T", {3, 4, 5});
  const auto result = pairwise_friedman_vs_control(BlockTable::from_observations(obs), "C", 0.05);
  ASSERT_EQ(result.size(), 1u);
  const PairwiseComparison& c = result[0];
  ASSERT_TRUE(c.p.has_value());
  EXPECT_EQ(c.replicates, 2u);
  EXPECT_EQ(c.dropped_observations, 4u);
  EXPECT_EQ(c.blocks_left_out, 0u);
  EXPECT_EQ(c.n_blocks, 3u);
  EXPECT_EQ(c.n_observations, 12u);
  EXPECT_NEAR(*c.statistic, 7.2, 1e-12);
  EXPECT_NEAR(*c.p, std::erfc(std::sqrt(3.6)), 1e-15);
}

// r = 3 keeps 2·3·2 = 12 (B1, B2), r = 1 keeps 2·1·3 = 6: B3 is left out.
TEST(PairwiseFriedmanTest, BalancingLeavesOutAShortBlockWhenThatKeepsMore) {
  std::vector<Observation> obs;
  const auto add = [&](const char* block, const char* treatment, std::vector<double> values) {
    for (double v : values) obs.push_back({block, treatment, "", v});
  };
  add("B1", "C", {1, 2, 3});
  add("B1", "T", {4, 5, 6});
  add("B2", "C", {1, 2, 3});
  add("B2", "T", {4, 5, 6});
  add("B3", "C", {1});
  add("B3", "T", {2, 3});
  const BalancedPair pair = balance_pair(BlockTable::from_observations(obs), 0, 1);
  EXPECT_EQ(pair.replicates, 3u);
  EXPECT_EQ(pair.available, 15u);
  EXPECT_EQ(pair.dropped, 3u);
  EXPECT_EQ(pair.blocks_left_out, 1u);
  EXPECT_EQ(pair.table.block_names, (std::vector<std::string>{"B1", "B2"}));
  EXPECT_EQ(pair.note(),
            "balanced to 3 repetition(s) per cell: 3 observation(s) dropped, 1 block(s) left out");
}

TEST(PairwiseFriedmanTest, UnknownControlListsTreatments) {
  try {
    pairwise_friedman_vs_control(BlockTable::from_observations(study()), "HighFidelity", 0.05);
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("'HighFidelity'"));
    EXPECT_THAT(e.what(), HasSubstr("HiFi, NoFFB"));
  }
}

}  // namespace
}  // namespace hapticlab::analysis
