#include "protocols/design.h"

#include <algorithm>
#include <cstdint>
#include <ostream>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

namespace hapticlab::protocols {
namespace {

// Thesis Table 3.2, optional part only. Columns: 0 Bckl (Inertia +
// Backlash), 1 Cogg, 2 Frict, 3 Inertia, 4 Sat.
const std::vector<std::vector<std::size_t>> kTable32 = {
    {0, 4},  // Surgeon 1
    {1, 2},  // Surgeon 2
    {2, 3},  // Surgeon 3
    {1, 4},  // Surgeon 4
    {1, 3},  // Surgeon 5
    {0, 2},  // Surgeon 6
    {0, 3},  // Surgeon 7
    {2, 4},  // Surgeon 8
};

TEST(DesignTest, Table32CountsAsInTheThesis) {
  const DesignBalance b = design_balance(kTable32, 5);
  EXPECT_EQ(b.item_counts, (std::vector<int>{3, 3, 4, 3, 3}));
  EXPECT_EQ(b.item_spread, 1);
  // 8 distinct pairs of the 10, each once: Bckl+Cogg and Inertia+Sat never.
  EXPECT_EQ(b.pair_counts[0][1], 0);
  EXPECT_EQ(b.pair_counts[3][4], 0);
  EXPECT_EQ(b.pair_counts[0][4], 1);
  EXPECT_EQ(b.pair_counts[4][0], 1);
  EXPECT_EQ(b.pair_spread, 1);
}

void expect_valid_subsets(const std::vector<std::vector<std::size_t>>& subsets, std::size_t n, std::size_t m,
                          std::size_t k) {
  ASSERT_EQ(subsets.size(), n);
  for (const auto& s : subsets) {
    ASSERT_EQ(s.size(), k);
    EXPECT_TRUE(std::is_sorted(s.begin(), s.end()));
    EXPECT_EQ(std::set<std::size_t>(s.begin(), s.end()).size(), k) << "an item twice in one subset";
    for (std::size_t x : s) EXPECT_LT(x, m);
  }
}

TEST(DesignTest, ReachesAtLeastTable32sBalanceForEightParticipants) {
  const DesignBalance table = design_balance(kTable32, 5);
  for (std::uint64_t seed : {0ULL, 1ULL, 2004ULL, 0xFFFFFFFFFFFFFFFFULL}) {
    const auto subsets = balanced_subsets(8, 5, 2, seed);
    expect_valid_subsets(subsets, 8, 5, 2);
    const DesignBalance b = design_balance(subsets, 5);
    EXPECT_LE(std::tie(b.item_spread, b.pair_spread), std::tie(table.item_spread, table.pair_spread))
        << "seed " << seed;
  }
}

// (participants, optional settings, k) and the balance each must reach.
// The exact ones are combinatorial designs that exist: (10,5,3) is every
// 3-subset of 5 (each pair 3 times), (6,4,2) every pair once, (7,7,3) the
// Fano plane (every pair exactly once).
struct Case {
  std::size_t n, m, k;
  int item_spread, pair_spread;
};

void PrintTo(const Case& c, std::ostream* os) {
  *os << "n=" << c.n << " m=" << c.m << " k=" << c.k << " ideal spreads " << c.item_spread << "/" << c.pair_spread;
}

class BalancedSubsetsTest : public ::testing::TestWithParam<Case> {};

TEST_P(BalancedSubsetsTest, ReachesTheIdealBalance) {
  const Case c = GetParam();
  EXPECT_EQ(ideal_item_spread(c.n, c.m, c.k), c.item_spread);
  EXPECT_EQ(ideal_pair_spread(c.n, c.m, c.k), c.pair_spread);
  for (std::uint64_t seed : {1ULL, 77ULL, 123456789ULL}) {
    const auto subsets = balanced_subsets(c.n, c.m, c.k, seed);
    expect_valid_subsets(subsets, c.n, c.m, c.k);
    const DesignBalance b = design_balance(subsets, c.m);
    EXPECT_EQ(b.item_spread, c.item_spread) << "seed " << seed;
    EXPECT_EQ(b.pair_spread, c.pair_spread) << "seed " << seed;
  }
}

INSTANTIATE_TEST_SUITE_P(Cases, BalancedSubsetsTest,
                         ::testing::Values(Case{8, 5, 2, 1, 1}, Case{3, 5, 2, 1, 1}, Case{10, 5, 3, 0, 0},
                                           Case{6, 4, 2, 0, 0}, Case{7, 7, 3, 0, 0}, Case{12, 6, 3, 0, 1},
                                           Case{5, 3, 1, 1, 0}, Case{20, 8, 4, 0, 1}),
                         [](const ::testing::TestParamInfo<Case>& info) {
                           const Case& c = info.param;
                           return "n" + std::to_string(c.n) + "_m" + std::to_string(c.m) + "_k" + std::to_string(c.k);
                         });

TEST(DesignTest, DeterministicGivenTheSeedAndVariesWithIt) {
  EXPECT_EQ(balanced_subsets(8, 5, 2, 42), balanced_subsets(8, 5, 2, 42));
  std::set<std::vector<std::vector<std::size_t>>> distinct;
  for (std::uint64_t seed = 0; seed < 10; ++seed) distinct.insert(balanced_subsets(8, 5, 2, seed));
  EXPECT_GT(distinct.size(), 1u) << "the seed never changes the design";
}

TEST(DesignTest, EdgeCasesOfK) {
  EXPECT_EQ(balanced_subsets(4, 5, 0, 1), std::vector<std::vector<std::size_t>>(4));
  EXPECT_EQ(balanced_subsets(2, 3, 3, 1), (std::vector<std::vector<std::size_t>>(2, {0, 1, 2})));
  EXPECT_THROW(balanced_subsets(2, 3, 4, 1), std::invalid_argument);
  EXPECT_TRUE(balanced_subsets(0, 5, 2, 1).empty());
}

Protocol three_settings_protocol() {
  Protocol p;
  p.study = "t";
  p.tasks = {Task::kClip};
  p.repetitions[Task::kClip] = 2;
  for (const char* name : {"High Fidelity", "No Force Feedback", "Friction", "Cogging"}) {
    ProtocolSetting s;
    s.settings.name = name;
    s.source = "inline";
    p.settings.push_back(s);
  }
  for (const char* code : {"A1", "A2", "A3", "A4"}) p.participants.push_back({code, {Task::kClip}, 0});
  return p;
}

TEST(DesignTest, AssignSettingsCompleteGivesEveryoneEverything) {
  const Protocol p = three_settings_protocol();
  const auto a = assign_settings(p);
  ASSERT_EQ(a.size(), 4u);
  for (const auto& s : a) EXPECT_EQ(s, (std::vector<std::size_t>{0, 1, 2, 3}));
}

TEST(DesignTest, AssignSettingsIncompleteKeepsRequiredAndBalancesTheRest) {
  Protocol p = three_settings_protocol();
  p.design.type = DesignType::kIncomplete;
  p.design.required = {"No Force Feedback"};
  p.design.k = 1;
  const auto a = assign_settings(p);
  ASSERT_EQ(a.size(), 4u);
  std::vector<int> optional_counts(4, 0);
  for (const auto& s : a) {
    ASSERT_EQ(s.size(), 2u);
    EXPECT_TRUE(std::is_sorted(s.begin(), s.end()));
    EXPECT_NE(std::find(s.begin(), s.end(), 1u), s.end()) << "required setting missing";
    for (std::size_t i : s) ++optional_counts[i];
  }
  // 4 participants, 3 optional settings, 1 each: counts 2,1,1 in some order.
  std::vector<int> opt{optional_counts[0], optional_counts[2], optional_counts[3]};
  std::sort(opt.begin(), opt.end());
  EXPECT_EQ(opt, (std::vector<int>{1, 1, 2}));
}

TEST(DesignTest, AssignSettingsExplicitFollowsTheTable) {
  Protocol p = three_settings_protocol();
  p.design.type = DesignType::kExplicit;
  p.design.assignments = {{"A1", {"Cogging", "High Fidelity"}},
                          {"A2", {"Friction", "No Force Feedback"}},
                          {"A3", {"High Fidelity", "No Force Feedback", "Friction"}},
                          {"A4", {"Cogging", "Friction"}}};
  const auto a = assign_settings(p);
  EXPECT_EQ(a[0], (std::vector<std::size_t>{0, 3}));
  EXPECT_EQ(a[1], (std::vector<std::size_t>{1, 2}));
  EXPECT_EQ(a[2], (std::vector<std::size_t>{0, 1, 2}));
  EXPECT_EQ(a[3], (std::vector<std::size_t>{2, 3}));
}

}  // namespace
}  // namespace hapticlab::protocols
