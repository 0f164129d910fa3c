#include "analysis/stats/skillings_mack.h"

#include <cmath>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/stats/data_error.h"
#include "analysis/stats/durbin.h"
#include "analysis/stats/friedman.h"

namespace hapticlab::analysis {
namespace {

using ::testing::HasSubstr;

// Skillings & Mack (1981), Table 1 p. 173: four methods (A–D) of assembling
// a product, nine blocks, with missing cells (NaN here), as in the R package
// Skillings.Mack's Ski.Mack example. Its output,
//   Skillings-Mack Statistic = 15.493049, p-value = 0.001440, d.f. = 3
// (as printed in the README of github.com/ZacWarham/Skillings.Mack, a fork of
// the CRAN package).
std::vector<Observation> assembly() {
  const double nan = std::nan("");
  const double y[9][4] = {{3.2, 4.1, 3.8, 4.2}, {3.1, 3.9, 3.4, 4.0}, {4.3, 3.5, 4.6, 4.8},
                          {3.5, 3.6, 3.9, 4.0}, {3.6, 4.2, 3.7, 3.9}, {4.5, 4.7, 3.7, nan},
                          {nan, 4.2, 3.4, nan}, {4.3, 4.6, 4.4, 4.9}, {3.5, nan, 3.7, 3.9}};
  const char* method[] = {"A", "B", "C", "D"};
  std::vector<Observation> obs;
  for (int b = 0; b < 9; ++b) {
    for (int t = 0; t < 4; ++t) {
      if (!std::isnan(y[b][t])) obs.push_back({std::to_string(b + 1), method[t], "", y[b][t]});
    }
  }
  return obs;
}

TEST(SkillingsMackTest, PublishedAssemblyExample) {
  const TestResult r = skillings_mack_test(BlockTable::from_observations(assembly()));
  EXPECT_NEAR(r.statistic, 15.493049, 5e-7);  // printed to 6 decimals
  EXPECT_EQ(r.df, 3.0);
  EXPECT_NEAR(r.p, 0.001440, 5e-7);
  EXPECT_EQ(r.blocks, 9u);
  EXPECT_EQ(r.observations, 32u);
}

// With complete blocks and no ties the statistic is Friedman's.
TEST(SkillingsMackTest, CompleteBlocksWithoutTiesEqualFriedman) {
  const BlockTable table = BlockTable::from_matrix(
      {{1, 2, 3, 4}, {2, 1, 4, 3}, {4, 3, 1, 2}, {1, 3, 2, 4}, {1, 2, 4, 3}});
  EXPECT_NEAR(skillings_mack_test(table).statistic, friedman_test(table).statistic, 1e-10);
}

// In a BIBD without ties it reduces to Durbin's statistic (Skillings & Mack
// 1981, section 3): Conover's ice cream data again, T = 12.
TEST(SkillingsMackTest, BalancedIncompleteBlocksEqualDurbin) {
  const int variety[] = {1, 2, 4, 2, 3, 5, 3, 4, 6, 4, 5, 7, 1, 5, 6, 2, 6, 7, 1, 3, 7};
  const double preference[] = {2, 3, 1, 3, 1, 2, 2, 1, 3, 1, 2, 3, 3, 1, 2, 3, 1, 2, 3, 1, 2};
  std::vector<Observation> obs;
  for (int i = 0; i < 21; ++i) {
    obs.push_back({std::to_string(i / 3), std::to_string(variety[i]), "", preference[i]});
  }
  const BlockTable table = BlockTable::from_observations(obs);
  EXPECT_NEAR(skillings_mack_test(table).statistic, durbin_test(table).chi_square.statistic, 1e-10);
}

TEST(SkillingsMackTest, LoneObservationsAreLeftOut) {
  auto obs = assembly();
  obs.push_back({"10", "A", "", 9.9});  // a block with one observation carries no information
  const TestResult r = skillings_mack_test(BlockTable::from_observations(obs));
  EXPECT_NEAR(r.statistic, 15.493049, 5e-7);
  EXPECT_EQ(r.blocks, 9u);
}

TEST(SkillingsMackTest, DisconnectedTreatmentsAreRejected) {
  const std::vector<Observation> obs = {{"1", "A", "", 1}, {"1", "B", "", 2}, {"2", "A", "", 2},
                                        {"2", "B", "", 1}, {"3", "C", "", 1}, {"3", "D", "", 2}};
  try {
    skillings_mack_test(BlockTable::from_observations(obs));
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("not connected"));
  }
}

TEST(SkillingsMackTest, ReplicatesAreRejected) {
  auto obs = assembly();
  obs.push_back(obs.front());
  EXPECT_THROW(skillings_mack_test(BlockTable::from_observations(obs)), DataError);
}

}  // namespace
}  // namespace hapticlab::analysis
