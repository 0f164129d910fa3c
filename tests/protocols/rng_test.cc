#include "protocols/rng.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <map>
#include <vector>

#include <gtest/gtest.h>

namespace hapticlab::protocols {
namespace {

// Published vectors: SplitMix64 for seed 1234567 (the reference splitmix64.c
// output, as on Rosetta Code) and for seed 0; xoshiro256** from state
// {1, 2, 3, 4} (the reference implementation's output, as in rand_xoshiro's
// test); FNV-1a 64 from the FNV reference values.
TEST(RngTest, SplitMix64MatchesThePublishedVectorForSeed1234567) {
  std::uint64_t state = 1234567;
  const std::array<std::uint64_t, 5> expected{6457827717110365317ULL, 3203168211198807973ULL,
                                              9817491932198370423ULL, 4593380528125082431ULL,
                                              16408922859458223821ULL};
  for (std::uint64_t e : expected) EXPECT_EQ(splitmix64_next(state), e);
}

TEST(RngTest, SplitMix64MatchesThePublishedVectorForSeed0) {
  std::uint64_t state = 0;
  EXPECT_EQ(splitmix64_next(state), 0xE220A8397B1DCDAFULL);
  EXPECT_EQ(splitmix64_next(state), 0x6E789E6AA1B965F4ULL);
  EXPECT_EQ(splitmix64_next(state), 0x06C45D188009454FULL);
  EXPECT_EQ(splitmix64_next(state), 0xF88BB8A8724C81ECULL);
}

TEST(RngTest, Xoshiro256StarStarMatchesTheReferenceFromState1234) {
  Rng rng = Rng::from_state(1, 2, 3, 4);
  const std::array<std::uint64_t, 10> expected{11520ULL,
                                               0ULL,
                                               1509978240ULL,
                                               1215971899390074240ULL,
                                               1216172134540287360ULL,
                                               607988272756665600ULL,
                                               16172922978634559625ULL,
                                               8476171486693032832ULL,
                                               10595114339597558777ULL,
                                               2904607092377533576ULL};
  for (std::uint64_t e : expected) EXPECT_EQ(rng.next(), e);
}

TEST(RngTest, Fnv1a64MatchesTheReferenceValues) {
  EXPECT_EQ(fnv1a64(""), 0xCBF29CE484222325ULL);
  EXPECT_EQ(fnv1a64("a"), 0xAF63DC4C8601EC8CULL);
  EXPECT_EQ(fnv1a64("foobar"), 0x85944171F73967E8ULL);
}

// Seeding is SplitMix64 into the four state words: the seeded generator is
// the reference xoshiro256** started from the SplitMix64 outputs.
TEST(RngTest, SeedingFillsTheStateWithSplitMix64Outputs) {
  std::uint64_t sm = 1234567;
  const std::uint64_t s0 = splitmix64_next(sm), s1 = splitmix64_next(sm), s2 = splitmix64_next(sm),
                      s3 = splitmix64_next(sm);
  Rng a(1234567);
  Rng b = Rng::from_state(s0, s1, s2, s3);
  for (int i = 0; i < 100; ++i) ASSERT_EQ(a.next(), b.next());
}

TEST(RngTest, StreamsDependOnSeedAndName) {
  Rng a = Rng::for_stream(42, "schedule/S1");
  Rng b = Rng::for_stream(42, "schedule/S1");
  Rng c = Rng::for_stream(42, "schedule/S2");
  Rng d = Rng::for_stream(43, "schedule/S1");
  const std::uint64_t first = a.next();
  EXPECT_EQ(first, b.next());
  EXPECT_NE(first, c.next());
  EXPECT_NE(first, d.next());
}

TEST(RngTest, UniformBelowStaysInRangeAndHitsEveryValue) {
  Rng rng(99);
  EXPECT_EQ(rng.uniform_below(0), 0u);
  EXPECT_EQ(rng.uniform_below(1), 0u);
  for (std::uint64_t n : {2ULL, 3ULL, 7ULL, 10ULL}) {
    std::vector<int> hits(n, 0);
    for (int i = 0; i < 10000; ++i) {
      const std::uint64_t x = rng.uniform_below(n);
      ASSERT_LT(x, n);
      ++hits[x];
    }
    // Each value within 20 % of 10000/n: a loose check that nothing is
    // grossly biased (the rejection step makes it exactly uniform).
    for (int h : hits) EXPECT_NEAR(h, 10000.0 / n, 0.2 * 10000.0 / n) << "n = " << n;
  }
  // A bound just above 2^63 rejects almost half the draws; still in range.
  const std::uint64_t big = (1ULL << 63) + 12345;
  for (int i = 0; i < 100; ++i) ASSERT_LT(rng.uniform_below(big), big);
}

// Golden: the first outputs of our own seeding and bounded draws, pinned so
// that a change to any step of the algorithm is caught on every platform.
TEST(RngTest, GoldenDrawsForSeed2004) {
  Rng rng(2004);
  std::vector<std::uint64_t> got;
  for (int i = 0; i < 8; ++i) got.push_back(rng.uniform_below(10));
  const std::vector<std::uint64_t> golden{7, 1, 5, 7, 3, 6, 7, 2};
  EXPECT_EQ(got, golden);
}

TEST(RngTest, ShuffleIsFisherYatesFromTheBack) {
  // Reproduce the shuffle by hand from the same draws.
  std::vector<int> v{0, 1, 2, 3, 4, 5};
  std::vector<int> expected = v;
  Rng a(77), b(77);
  shuffle(v, a);
  for (std::size_t i = expected.size(); i > 1; --i) std::swap(expected[i - 1], expected[b.uniform_below(i)]);
  EXPECT_EQ(v, expected);
  // Generator advanced by exactly n - 1 draws (no hidden extra draws) -- for
  // these bounds rejection is vanishingly rare, so both streams line up.
  EXPECT_EQ(a.next(), b.next());
}

TEST(RngTest, ShuffleIsAPermutationAndRoughlyUniform) {
  Rng rng(5);
  std::map<std::vector<int>, int> seen;
  for (int i = 0; i < 6000; ++i) {
    std::vector<int> v{0, 1, 2};
    shuffle(v, rng);
    std::vector<int> sorted = v;
    std::sort(sorted.begin(), sorted.end());
    ASSERT_EQ(sorted, (std::vector<int>{0, 1, 2}));
    ++seen[v];
  }
  ASSERT_EQ(seen.size(), 6u);
  for (const auto& [perm, count] : seen) EXPECT_NEAR(count, 1000, 150);
}

TEST(RngTest, ShuffleOfEmptyAndSingleDrawsNothing) {
  Rng a(1), b(1);
  std::vector<int> empty, one{7};
  shuffle(empty, a);
  shuffle(one, a);
  EXPECT_EQ(one, std::vector<int>{7});
  EXPECT_EQ(a.next(), b.next());
}

}  // namespace
}  // namespace hapticlab::protocols
