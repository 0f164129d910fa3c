#include "analysis/stats/moving_block_bootstrap.h"

#include <vector>

#include <gtest/gtest.h>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {
namespace {

// series[i] = i, so a value names its position and blocks are easy to see.
std::vector<double> ramp(int n) {
  std::vector<double> v;
  for (int i = 0; i < n; ++i) v.push_back(i);
  return v;
}

// Every output block of L samples is L consecutive input samples; the last
// block is cut so the output has the input's length.
TEST(MovingBlockBootstrapTest, OutputIsMadeOfConsecutiveBlocks) {
  const auto series = ramp(23);
  constexpr std::size_t kBlock = 5;
  SplitMix64 rng(7);
  std::vector<double> out;
  for (int trial = 0; trial < 50; ++trial) {
    moving_block_resample(series, kBlock, rng, out);
    ASSERT_EQ(out.size(), series.size());
    for (std::size_t i = 0; i < out.size(); ++i) {
      ASSERT_GE(out[i], 0.0);
      ASSERT_LE(out[i], 22.0);
      if (i % kBlock != 0) {
        ASSERT_EQ(out[i], out[i - 1] + 1.0) << "at " << i;
      }
    }
    for (std::size_t i = 0; i < out.size(); i += kBlock) {
      ASSERT_LE(out[i], 23.0 - kBlock);  // a block never runs off the end
    }
  }
}

TEST(MovingBlockBootstrapTest, WholeSeriesBlockReproducesTheSeries) {
  const auto series = ramp(10);
  SplitMix64 rng(1);
  std::vector<double> out;
  moving_block_resample(series, 10, rng, out);
  EXPECT_EQ(out, series);
}

TEST(MovingBlockBootstrapTest, DeterministicGivenSeed) {
  const auto series = ramp(100);
  std::vector<double> a;
  std::vector<double> b;
  std::vector<double> c;
  SplitMix64 ra(99);
  SplitMix64 rb(99);
  SplitMix64 rc(100);
  moving_block_resample(series, 8, ra, a);
  moving_block_resample(series, 8, rb, b);
  moving_block_resample(series, 8, rc, c);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
}

TEST(MovingBlockBootstrapTest, RejectsBadBlockLength) {
  const auto series = ramp(4);
  SplitMix64 rng(1);
  std::vector<double> out;
  EXPECT_THROW(moving_block_resample(series, 0, rng, out), DataError);
  EXPECT_THROW(moving_block_resample(series, 5, rng, out), DataError);
  EXPECT_THROW(moving_block_resample(std::vector<double>{}, 1, rng, out), DataError);
}

}  // namespace
}  // namespace hapticlab::analysis
