#include "analysis/stats/ks_bootstrap.h"

#include <cmath>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/stats/data_error.h"
#include "analysis/stats/kolmogorov_smirnov.h"
#include "analysis/stats/moving_block_bootstrap.h"
#include "analysis/stats/split_mix64.h"

namespace hapticlab::analysis {
namespace {

using ::testing::HasSubstr;

// A smooth, autocorrelated series (a slow sine plus a per-repetition phase)
// of n samples around `offset`.
std::vector<double> series(double offset, double phase, int n = 200) {
  std::vector<double> v;
  for (int i = 0; i < n; ++i) v.push_back(offset + std::sin(0.05 * i + phase));
  return v;
}

std::vector<ParticipantRepetitions> study(double other_offset) {
  std::vector<ParticipantRepetitions> data;
  for (int p = 0; p < 3; ++p) {
    ParticipantRepetitions r;
    r.participant = "S" + std::to_string(p + 1);
    for (int rep = 0; rep < 3; ++rep) r.control.push_back(series(0.0, 0.7 * rep + p));
    for (int rep = 0; rep < 3; ++rep) r.other.push_back(series(other_offset, 0.5 * rep + p));
    data.push_back(std::move(r));
  }
  return data;
}

KsBootstrapOptions options(std::uint64_t seed = 5) {
  KsBootstrapOptions o;
  o.resamples = 200;
  o.block_length = 20;
  o.seed = seed;
  return o;
}

TEST(KsBootstrapTest, DeterministicGivenSeed) {
  const auto data = study(0.3);
  const auto a = ks_block_bootstrap(data, options(5));
  const auto b = ks_block_bootstrap(data, options(5));
  const auto c = ks_block_bootstrap(data, options(6));
  EXPECT_EQ(a.d_intra, b.d_intra);
  EXPECT_EQ(a.d_inter, b.d_inter);
  EXPECT_EQ(a.intra.low, b.intra.low);
  EXPECT_EQ(a.inter.high, b.inter.high);
  EXPECT_NE(a.d_intra, c.d_intra);
  EXPECT_EQ(a.d_intra.size(), 200u);
}

// Shifted by 5 (far outside the sine's ±1): every D_inter is 1, while
// repetitions of the control overlap, so the ranges are disjoint.
TEST(KsBootstrapTest, ClearShiftIsSignificant) {
  const auto r = ks_block_bootstrap(study(5.0), options());
  EXPECT_EQ(r.inter.low, 1.0);
  EXPECT_LT(r.intra.high, 1.0);
  EXPECT_TRUE(r.significant);
  EXPECT_EQ(r.participants_used, 3u);
}

// The other setting drawn like the control: the ranges overlap.
TEST(KsBootstrapTest, SameDistributionIsNotSignificant) {
  const auto r = ks_block_bootstrap(study(0.0), options());
  EXPECT_FALSE(r.significant);
  for (double d : r.d_intra) {
    EXPECT_GE(d, 0.0);
    EXPECT_LE(d, 1.0);
  }
}

TEST(KsBootstrapTest, RangesDisjointRule) {
  EXPECT_TRUE(ranges_disjoint({0.1, 0.3}, {0.31, 0.5}));
  EXPECT_TRUE(ranges_disjoint({0.4, 0.5}, {0.1, 0.3}));
  EXPECT_FALSE(ranges_disjoint({0.1, 0.3}, {0.3, 0.5}));  // touching is overlapping
  EXPECT_FALSE(ranges_disjoint({0.1, 0.6}, {0.2, 0.3}));
}

// A participant with one control repetition cannot supply HF1 != HF2.
TEST(KsBootstrapTest, ParticipantsNeedTwoControlRepetitions) {
  auto data = study(5.0);
  data[0].control.resize(1);
  data[1].other.clear();
  const auto r = ks_block_bootstrap(data, options());
  EXPECT_EQ(r.participants_used, 1u);
  data[2].control.resize(1);
  try {
    ks_block_bootstrap(data, options());
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("at least 2 control repetitions"));
  }
}

TEST(KsBootstrapTest, ShortSeriesIsNamed) {
  auto data = study(0.0);
  data[1].other[2].resize(10);  // shorter than the block length 20
  try {
    ks_block_bootstrap(data, options());
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("'S2'"));
    EXPECT_THAT(e.what(), HasSubstr("other repetition 3"));
  }
}

TEST(KsBootstrapTest, BlockLengthIsRequired) {
  KsBootstrapOptions o = options();
  o.block_length = 0;
  EXPECT_THROW(ks_block_bootstrap(study(0.0), o), DataError);
}

// With m < 40 the 95 % range is the smallest and largest D: with a single
// resample, two degenerate ranges that did not overlap "showed" a
// significant difference in data without one. At least 100 are required.
TEST(KsBootstrapTest, TooFewResamplesForA95PercentRangeAreRefused) {
  KsBootstrapOptions o = options();
  for (const std::size_t m : {std::size_t{1}, std::size_t{39}, std::size_t{99}}) {
    o.resamples = m;
    EXPECT_THAT([&] { ks_block_bootstrap(study(0.0), o); },
                ::testing::ThrowsMessage<DataError>(HasSubstr("resamples is " + std::to_string(m) +
                                                              ", but must be >= 100")));
  }
  o.resamples = 100;
  EXPECT_NO_THROW(ks_block_bootstrap(study(0.0), o));
}


// The bootstrap counts ranks instead of sorting each resample; it must give
// the very D values of the plain procedure (resample, sort, ks_statistic),
// ties included: here every value is rounded to 0.1, so ties abound, and the
// participants differ in repetition counts and series lengths.
TEST(KsBootstrapTest, RankCountingMatchesSortingBitForBit) {
  std::vector<ParticipantRepetitions> data;
  for (int p = 0; p < 3; ++p) {
    ParticipantRepetitions r;
    r.participant = "S" + std::to_string(p + 1);
    for (int rep = 0; rep < 2 + p; ++rep) {
      auto s = series(0.0, 0.3 * rep + p, 150 + 40 * rep);
      for (double& v : s) v = std::round(v * 10) / 10;
      r.control.push_back(s);
    }
    for (int rep = 0; rep < 3; ++rep) {
      auto s = series(0.4 * p, 0.9 * rep, 180);
      for (double& v : s) v = std::round(v * 10) / 10;
      r.other.push_back(s);
    }
    data.push_back(std::move(r));
  }
  KsBootstrapOptions o = options(11);
  o.block_length = 7;
  const auto fast = ks_block_bootstrap(data, o);

  SplitMix64 rng(o.seed);
  std::vector<double> hf1, hf2, si1;
  for (std::size_t m = 0; m < o.resamples; ++m) {
    const auto& p = data[rng.below(data.size())];
    const auto first = static_cast<std::size_t>(rng.below(p.control.size()));
    auto second = static_cast<std::size_t>(rng.below(p.control.size() - 1));
    if (second >= first) ++second;
    const auto other = static_cast<std::size_t>(rng.below(p.other.size()));
    moving_block_resample(p.control[first], o.block_length, rng, hf1);
    moving_block_resample(p.control[second], o.block_length, rng, hf2);
    moving_block_resample(p.other[other], o.block_length, rng, si1);
    ASSERT_EQ(fast.d_intra[m], ks_statistic(hf1, hf2)) << "resample " << m;
    ASSERT_EQ(fast.d_inter[m], ks_statistic(hf1, si1)) << "resample " << m;
  }
}

}  // namespace
}  // namespace hapticlab::analysis
