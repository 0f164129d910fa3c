#include "analysis/stats/durbin.h"

#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {
namespace {

using ::testing::HasSubstr;

// Conover (1999), Practical Nonparametric Statistics, 3rd ed., p. 391: seven
// judges (blocks) each rank three of seven ice cream varieties, a BIBD with
// t = 7, k = 3, r = 3, λ = 1. As in R agricolae's durbin.test example 1:
//   person <- gl(7,3)
//   variety <- c(1,2,4, 2,3,5, 3,4,6, 4,5,7, 1,5,6, 2,6,7, 1,3,7)
//   preference <- c(2,3,1, 3,1,2, 2,1,3, 1,2,3, 3,1,2, 3,1,2, 3,1,2)
// agricolae prints (https://myaseen208.com/agricolae/reference/durbin.test.html):
//   sums of ranks 8, 9, 4, 3, 5, 6, 7; Value 12, DF 1: 6, P-value 0.0619688
// By hand: r(k+1)/2 = 6, Σ(R_j − 6)² = 4+9+4+9+1+0+1 = 28,
//   T1 = 12·(t−1)/(r·t·(k−1)(k+1)) · 28 = 72/168 · 28 = 12.
//   F form: T2 = (12/6)/((b(k−1) − 12)/(bk − b − t + 1)) = 2/((14 − 12)/8) = 8.
std::vector<Observation> ice_cream() {
  const int variety[] = {1, 2, 4, 2, 3, 5, 3, 4, 6, 4, 5, 7, 1, 5, 6, 2, 6, 7, 1, 3, 7};
  const double preference[] = {2, 3, 1, 3, 1, 2, 2, 1, 3, 1, 2, 3, 3, 1, 2, 3, 1, 2, 3, 1, 2};
  std::vector<Observation> obs;
  for (int i = 0; i < 21; ++i) {
    obs.push_back({"judge" + std::to_string(i / 3 + 1), "v" + std::to_string(variety[i]), "",
                   preference[i]});
  }
  return obs;
}

TEST(DurbinTest, ConoverIceCreamMatchesAgricolae) {
  const DurbinResult r = durbin_test(BlockTable::from_observations(ice_cream()));
  EXPECT_NEAR(r.chi_square.statistic, 12.0, 1e-12);
  EXPECT_EQ(r.chi_square.df, 6.0);
  EXPECT_NEAR(r.chi_square.p, 0.0619688, 5e-8);  // printed to 7 digits
  EXPECT_EQ(r.chi_square.blocks, 7u);
  EXPECT_EQ(r.chi_square.treatments, 7u);
  EXPECT_EQ(r.chi_square.observations, 21u);
  EXPECT_NEAR(r.f, 8.0, 1e-12);
  EXPECT_EQ(r.f_df1, 6.0);
  EXPECT_EQ(r.f_df2, 8.0);
}

TEST(DurbinTest, UnequalBlockSizesAreRejected) {
  auto obs = ice_cream();
  obs.pop_back();  // judge 7 now tastes only two varieties
  try {
    durbin_test(BlockTable::from_observations(obs));
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("'judge7'"));
    EXPECT_THAT(e.what(), HasSubstr("Skillings-Mack"));
  }
}

TEST(DurbinTest, UnbalancedPairsAreRejected) {
  // 4 blocks of 2 over 4 treatments, each treatment twice, but A meets B twice
  // and C never.
  const std::vector<Observation> obs = {
      {"1", "A", "", 1}, {"1", "B", "", 2}, {"2", "A", "", 1}, {"2", "B", "", 2},
      {"3", "C", "", 1}, {"3", "D", "", 2}, {"4", "C", "", 1}, {"4", "D", "", 2}};
  try {
    durbin_test(BlockTable::from_observations(obs));
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("not balanced"));
  }
}

TEST(DurbinTest, ReplicatesAreRejected) {
  auto obs = ice_cream();
  obs.push_back(obs.front());
  EXPECT_THROW(durbin_test(BlockTable::from_observations(obs)), DataError);
}

}  // namespace
}  // namespace hapticlab::analysis
