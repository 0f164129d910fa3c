#include "analysis/stats/percentile.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {
namespace {

using ::testing::HasSubstr;

// Interpolation of exact decimal data: only rounding error.
constexpr double kTolerance = 1e-12;

// MATLAB prctile, worked by hand for x = {10, 20, 30, 40} (n = 4): the sorted
// values sit at percentiles 100(i − 0.5)/4 = 12.5, 37.5, 62.5, 87.5.
//   p = 50: halfway between 37.5 (20) and 62.5 (30)          -> 25
//   p = 25: 12.5 + 12.5, halfway between 10 and 20           -> 15
//   p = 80: 62.5 + 17.5 = 0.7 of the way from 30 to 40       -> 37
//   p = 10: below 12.5, clamped to the minimum               -> 10
//   p = 95: above 87.5, clamped to the maximum               -> 40
TEST(PercentileTest, MatlabDefinitionByHand) {
  const std::vector<double> x = {30, 10, 40, 20};  // order must not matter
  EXPECT_NEAR(percentile(x, 50), 25.0, kTolerance);
  EXPECT_NEAR(percentile(x, 25), 15.0, kTolerance);
  EXPECT_NEAR(percentile(x, 80), 37.0, kTolerance);
  EXPECT_NEAR(percentile(x, 10), 10.0, kTolerance);
  EXPECT_NEAR(percentile(x, 95), 40.0, kTolerance);
  EXPECT_NEAR(percentile(x, 0), 10.0, kTolerance);
  EXPECT_NEAR(percentile(x, 100), 40.0, kTolerance);
}

// n = 5, x = 1..5 at 10, 30, 50, 70, 90: p = 50 is x(3); p = 95 clamps to 5;
// p = 20 is halfway between 10 (1) and 30 (2).
TEST(PercentileTest, MatlabOddCount) {
  const std::vector<double> x = {1, 2, 3, 4, 5};
  EXPECT_NEAR(percentile(x, 50, PercentileMethod::kMatlab), 3.0, kTolerance);
  EXPECT_NEAR(percentile(x, 95, PercentileMethod::kMatlab), 5.0, kTolerance);
  EXPECT_NEAR(percentile(x, 20, PercentileMethod::kMatlab), 1.5, kTolerance);
}

// R type 7 / numpy: h = 3p/100 + 1 for n = 4.
//   p = 25: h = 1.75 -> 17.5;  p = 95: h = 3.85 -> 38.5 (numpy.percentile gives 38.5)
TEST(PercentileTest, R7ByHand) {
  const std::vector<double> x = {10, 20, 30, 40};
  EXPECT_NEAR(percentile(x, 25, PercentileMethod::kR7), 17.5, kTolerance);
  EXPECT_NEAR(percentile(x, 95, PercentileMethod::kR7), 38.5, kTolerance);
  EXPECT_NEAR(percentile(x, 50, PercentileMethod::kR7), 25.0, kTolerance);
}

// R type 6: h = 5p/100 for n = 4.
//   p = 25: h = 1.25 -> 12.5;  p = 95: h = 4.75 > n -> 40;  p = 10: h = 0.5 -> 10
TEST(PercentileTest, R6ByHand) {
  const std::vector<double> x = {10, 20, 30, 40};
  EXPECT_NEAR(percentile(x, 25, PercentileMethod::kR6), 12.5, kTolerance);
  EXPECT_NEAR(percentile(x, 95, PercentileMethod::kR6), 40.0, kTolerance);
  EXPECT_NEAR(percentile(x, 10, PercentileMethod::kR6), 10.0, kTolerance);
}

// Nearest rank: x(ceil(4p/100)).
TEST(PercentileTest, NearestRankByHand) {
  const std::vector<double> x = {10, 20, 30, 40};
  EXPECT_EQ(percentile(x, 25, PercentileMethod::kNearestRank), 10.0);  // rank 1
  EXPECT_EQ(percentile(x, 26, PercentileMethod::kNearestRank), 20.0);  // rank ceil(1.04) = 2
  EXPECT_EQ(percentile(x, 50, PercentileMethod::kNearestRank), 20.0);
  EXPECT_EQ(percentile(x, 95, PercentileMethod::kNearestRank), 40.0);
  EXPECT_EQ(percentile(x, 0, PercentileMethod::kNearestRank), 10.0);
  // 95 % of 20 values is exactly rank 19, not 20
  std::vector<double> twenty;
  for (int i = 1; i <= 20; ++i) twenty.push_back(i);
  EXPECT_EQ(percentile(twenty, 95, PercentileMethod::kNearestRank), 19.0);
}

TEST(PercentileTest, SingleValue) {
  const std::vector<double> x = {7.5};
  for (auto m : {PercentileMethod::kMatlab, PercentileMethod::kR7, PercentileMethod::kR6,
                 PercentileMethod::kNearestRank}) {
    EXPECT_EQ(percentile(x, 95, m), 7.5);
  }
}

TEST(PercentileTest, ParsesNames) {
  EXPECT_EQ(parse_percentile_method("matlab"), PercentileMethod::kMatlab);
  EXPECT_EQ(parse_percentile_method("r5"), PercentileMethod::kMatlab);
  EXPECT_EQ(parse_percentile_method("r7"), PercentileMethod::kR7);
  EXPECT_EQ(parse_percentile_method("numpy"), PercentileMethod::kR7);
  EXPECT_EQ(parse_percentile_method("r6"), PercentileMethod::kR6);
  EXPECT_EQ(parse_percentile_method("nearest"), PercentileMethod::kNearestRank);
  for (auto m : {PercentileMethod::kMatlab, PercentileMethod::kR7, PercentileMethod::kR6,
                 PercentileMethod::kNearestRank}) {
    EXPECT_EQ(parse_percentile_method(percentile_method_name(m)), m);
  }
}

TEST(PercentileTest, UnknownNameSaysWhatIsAccepted) {
  try {
    parse_percentile_method("excel2007");
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("'excel2007'"));
    EXPECT_THAT(e.what(), HasSubstr("matlab"));
    EXPECT_THAT(e.what(), HasSubstr("r7"));
  }
}

TEST(PercentileTest, RejectsBadInput) {
  const std::vector<double> x = {1, 2};
  EXPECT_THROW(percentile(x, -1), DataError);
  EXPECT_THROW(percentile(x, 100.5), DataError);
  EXPECT_THROW(percentile(std::vector<double>{}, 50), DataError);
  EXPECT_THROW(percentile(std::vector<double>{1.0, std::nan("")}, 50), DataError);
}


// Selection finds the same order statistics as a full sort, so every
// definition gives bit-identical percentiles; ties (values rounded to 0.25)
// and tiny samples included.
TEST(PercentileTest, SelectionMatchesSortingExactly) {
  std::uint64_t state = 12345;
  auto next = [&state] {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(state >> 11) * 0x1.0p-53;
  };
  std::vector<double> all_ps;
  for (int i = 0; i <= 200; ++i) all_ps.push_back(i * 0.5);
  all_ps.push_back(95.0);
  all_ps.push_back(12.345);
  // Without ties too, so a misplaced order statistic cannot pass as its
  // equal neighbour; and the two percentiles analyze asks for alone.
  struct Case {
    std::size_t n;
    bool ties, grid;
  };
  std::vector<Case> cases;
  for (std::size_t n : {1u, 2u, 3u, 7u, 100u, 1001u, 1002u, 1009u})
    for (const bool ties : {true, false})
      for (const bool grid : {true, false}) cases.push_back({n, ties, grid});
  for (const auto& [n, ties, grid] : cases) {
    std::vector<double> values;
    for (std::size_t i = 0; i < n; ++i) values.push_back(ties ? std::round(next() * 40.0) / 4.0 : next());
    const std::vector<double> ps = grid ? all_ps : std::vector<double>{50.0, 95.0};
    std::vector<double> sorted = values;
    std::sort(sorted.begin(), sorted.end());
    for (auto method : {PercentileMethod::kMatlab, PercentileMethod::kR7, PercentileMethod::kR6,
                        PercentileMethod::kNearestRank}) {
      std::vector<double> scratch = values;
      const std::vector<double> selected = percentiles_select(scratch, ps, method);
      ASSERT_EQ(selected.size(), ps.size());
      for (std::size_t k = 0; k < ps.size(); ++k) {
        ASSERT_EQ(selected[k], percentile_sorted(sorted, ps[k], method))
            << "n " << n << " ties " << ties << " p " << ps[k] << " method " << percentile_method_name(method);
      }
    }
  }
}

}  // namespace
}  // namespace hapticlab::analysis
