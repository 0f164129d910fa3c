#include "analysis/stats/ks_rank_walk.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "analysis/stats/split_mix64.h"

namespace hapticlab::analysis {
namespace {

// The walk as the bootstrap first wrote it: three divisions per rank.
KsPairD divide_every_rank(const std::vector<std::uint32_t>& count1, const std::vector<std::uint32_t>& count2,
                          const std::vector<std::uint32_t>& count3) {
  double n1 = 0, n2 = 0, n3 = 0;
  for (std::size_t u = 0; u < count1.size(); ++u) {
    n1 += count1[u];
    n2 += count2[u];
    n3 += count3[u];
  }
  std::size_t c1 = 0, c2 = 0, c3 = 0;
  KsPairD d;
  for (std::size_t u = 0; u < count1.size(); ++u) {
    if ((count1[u] | count2[u] | count3[u]) == 0) continue;
    c1 += count1[u];
    c2 += count2[u];
    c3 += count3[u];
    const double f1 = static_cast<double>(c1) / n1;
    d.d12 = std::max(d.d12, std::fabs(f1 - static_cast<double>(c2) / n2));
    d.d13 = std::max(d.d13, std::fabs(f1 - static_cast<double>(c3) / n3));
  }
  return d;
}

std::vector<std::uint32_t> histogram(SplitMix64& rng, std::size_t levels, std::size_t n, std::size_t skew) {
  std::vector<std::uint32_t> h(levels, 0);
  for (std::size_t i = 0; i < n; ++i) {
    // Skewed towards low or high ranks so the two step functions part.
    std::size_t u = static_cast<std::size_t>(rng.below(levels));
    if (skew > 0) u = std::min(u, static_cast<std::size_t>(rng.below(levels)));
    ++h[u];
  }
  return h;
}

// The bitmap of ranks any sample took, as the bootstrap sets it.
std::vector<std::uint64_t> touched(const std::vector<std::uint32_t>& h1, const std::vector<std::uint32_t>& h2,
                                   const std::vector<std::uint32_t>& h3) {
  std::vector<std::uint64_t> bits((h1.size() + 63) / 64, 0);
  for (std::size_t u = 0; u < h1.size(); ++u) {
    if ((h1[u] | h2[u] | h3[u]) != 0) bits[u / 64] |= std::uint64_t{1} << (u % 64);
  }
  return bits;
}

// Equal sample sizes make equal exact gaps common at different ranks, and
// there c1/n − c2/n rounds differently by an ulp: the walk must keep the
// largest rounded value among them, as the three divisions did. Sizes in a
// ratio (n1 = 3·n2) and coprime ones are covered too, with few and many ranks.
TEST(KsRankWalkTest, GivesTheDividingWalksStatisticsBitForBit) {
  SplitMix64 rng(20261128);
  std::size_t ulp_ties_seen = 0;
  struct Case {
    std::size_t levels, n1, n2, n3;
  };
  for (const Case c : {Case{40, 1000, 1000, 1000}, Case{5000, 3000, 1000, 997}, Case{300, 49, 49, 7},
                       Case{20000, 18700, 18700, 18690}}) {
    const int trials = c.n1 > 5000 ? 30 : 300;  // the demo's size: a few are enough
    for (int trial = 0; trial < trials; ++trial) {
      auto h1 = histogram(rng, c.levels, c.n1, 0);
      auto h2 = histogram(rng, c.levels, c.n2, static_cast<std::size_t>(trial % 2));
      auto h3 = histogram(rng, c.levels, c.n3, 1);
      const KsPairD want = divide_every_rank(h1, h2, h3);
      auto w1 = h1, w2 = h2, w3 = h3;
      auto bits = touched(w1, w2, w3);
      const KsPairD got = ks_rank_walk(w1, w2, w3, bits, c.levels, c.n1, c.n2, c.n3);
      EXPECT_TRUE(std::all_of(bits.begin(), bits.end(), [](auto v) { return v == 0; }));
      ASSERT_EQ(got.d12, want.d12) << c.levels << " levels, n " << c.n1 << "/" << c.n2 << ", trial " << trial;
      ASSERT_EQ(got.d13, want.d13) << c.levels << " levels, n " << c.n1 << "/" << c.n3 << ", trial " << trial;
      EXPECT_TRUE(std::all_of(w1.begin(), w1.end(), [](auto v) { return v == 0; }));
      EXPECT_TRUE(std::all_of(w2.begin(), w2.end(), [](auto v) { return v == 0; }));
      EXPECT_TRUE(std::all_of(w3.begin(), w3.end(), [](auto v) { return v == 0; }));
      // Count the resamples where the first rank with the largest exact gap
      // is not the one with the largest rounded gap: the case the tie rule is for.
      double first_at_max = -1.0;
      std::int64_t best = -1, a = 0, b = 0;
      for (std::size_t u = 0; u < c.levels; ++u) {
        if ((h1[u] | h2[u] | h3[u]) == 0) continue;
        a += h1[u];
        b += h2[u];
        const std::int64_t gap = std::llabs(a * static_cast<std::int64_t>(c.n2) - b * static_cast<std::int64_t>(c.n1));
        if (gap > best) {
          best = gap;
          first_at_max = std::fabs(static_cast<double>(a) / static_cast<double>(c.n1) -
                                   static_cast<double>(b) / static_cast<double>(c.n2));
        }
      }
      if (first_at_max != want.d12) ++ulp_ties_seen;
    }
  }
  // The data must exercise the tie rule, or the test proves less than it says.
  EXPECT_GT(ulp_ties_seen, 0u);
}

// Beyond n1·n2 = 2^40 the integer gaps would be too fine to order the
// rounded ones, and the walk divides at every rank instead.
TEST(KsRankWalkTest, VeryLargeSamplesTakeTheDividingPath) {
  SplitMix64 rng(7);
  const std::size_t levels = 64;
  auto h1 = histogram(rng, levels, 1'200'000, 0);
  auto h2 = histogram(rng, levels, 1'100'000, 1);
  auto h3 = histogram(rng, levels, 1'000'003, 1);
  const KsPairD want = divide_every_rank(h1, h2, h3);
  auto bits = touched(h1, h2, h3);
  const KsPairD got = ks_rank_walk(h1, h2, h3, bits, levels, 1'200'000, 1'100'000, 1'000'003);
  EXPECT_EQ(got.d12, want.d12);
  EXPECT_EQ(got.d13, want.d13);
  EXPECT_GT(got.d12, 0.0);
}

}  // namespace
}  // namespace hapticlab::analysis
