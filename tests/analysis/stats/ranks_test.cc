#include "analysis/stats/ranks.h"

#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace hapticlab::analysis {
namespace {

using ::testing::ElementsAre;

TEST(RanksTest, TiesShareTheMeanRank) {
  // sorted: 1, 1 (ranks 1, 2 -> 1.5), 3, 4, 5; one pair tied: 2³ − 2 = 6
  const Ranking r = average_ranks(std::vector<double>{3, 1, 4, 1, 5});
  EXPECT_THAT(r.ranks, ElementsAre(3.0, 1.5, 4.0, 1.5, 5.0));
  EXPECT_EQ(r.tie_term, 6.0);
}

TEST(RanksTest, NoTies) {
  const Ranking r = average_ranks(std::vector<double>{0.3, -2.0, 7.0});
  EXPECT_THAT(r.ranks, ElementsAre(2.0, 1.0, 3.0));
  EXPECT_EQ(r.tie_term, 0.0);
}

TEST(RanksTest, AllTied) {
  // three tied: ranks 1..3 average to 2; 3³ − 3 = 24
  const Ranking r = average_ranks(std::vector<double>{2, 2, 2});
  EXPECT_THAT(r.ranks, ElementsAre(2.0, 2.0, 2.0));
  EXPECT_EQ(r.tie_term, 24.0);
}

TEST(RanksTest, Empty) {
  const Ranking r = average_ranks(std::vector<double>{});
  EXPECT_TRUE(r.ranks.empty());
  EXPECT_EQ(r.tie_term, 0.0);
}

}  // namespace
}  // namespace hapticlab::analysis
