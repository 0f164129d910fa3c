#include "core/loop/loop_timing.h"

#include <cmath>
#include <limits>
#include <thread>

#include <gtest/gtest.h>

#include "core/common/random.h"

namespace hapticlab {
namespace {

constexpr double kUs = 1e-6;

TEST(LoopTimingStatsTest, EmptySummaryIsAllZero) {
  LoopTimingStats stats;
  const LoopTimingSummary s = stats.summary();
  EXPECT_EQ(s.count, 0u);
  EXPECT_EQ(s.mean_period_s, 0.0);
  EXPECT_EQ(s.p50_period_s, 0.0);
  EXPECT_EQ(s.p99_period_s, 0.0);
  EXPECT_EQ(s.max_period_s, 0.0);
}

TEST(LoopTimingStatsTest, PercentilesMatchAHandComputedSet) {
  // Periods (1000 + 10·k + 0.5) µs for k = 1..100, in a shuffled order; every
  // 10th one overran. Nearest rank: p50 is the 50th smallest (k = 50), p99
  // the 99th (k = 99). Each sits at a bin centre, so the histogram is exact.
  LoopTimingStats stats;
  int order[100];
  for (int k = 0; k < 100; ++k) order[k] = k + 1;
  Random rng(3);
  for (int k = 99; k > 0; --k) std::swap(order[k], order[rng.below(k + 1)]);
  for (int k : order) stats.record((1000.0 + 10.0 * k + 0.5) * kUs, k % 10 == 0);

  const LoopTimingSummary s = stats.summary();
  EXPECT_EQ(s.count, 100u);
  EXPECT_EQ(s.overruns, 10u);
  EXPECT_NEAR(s.mean_period_s, (1000.5 + 10.0 * 50.5) * kUs, 1e-12);
  EXPECT_NEAR(s.p50_period_s, 1500.5 * kUs, 1e-12);
  EXPECT_NEAR(s.p99_period_s, 1990.5 * kUs, 1e-12);
  EXPECT_EQ(s.max_period_s, 2000.5 * kUs);
}

TEST(LoopTimingStatsTest, PercentileIsWithinHalfABinAndNeverAboveTheMax) {
  LoopTimingStats stats;
  stats.record(1234.9 * kUs, false);  // bin [1234, 1235) µs, centre 1234.5
  const LoopTimingSummary s = stats.summary();
  EXPECT_NEAR(s.p50_period_s, 1234.5 * kUs, 1e-12);
  stats.reset();
  stats.record(1234.1 * kUs, false);  // the bin centre is above the sample
  EXPECT_EQ(stats.summary().p99_period_s, 1234.1 * kUs);
}

TEST(LoopTimingStatsTest, LongPeriodsLandInTheOverflowBinWithAnExactMax) {
  LoopTimingStats stats;
  for (int k = 0; k < 98; ++k) stats.record(1000.4 * kUs, false);
  stats.record(0.25, true);
  stats.record(3600.0, true);  // a stall of an hour
  const LoopTimingSummary s = stats.summary();
  EXPECT_EQ(s.count, 100u);
  EXPECT_NEAR(s.p50_period_s, 1000.5 * kUs, 1e-12);
  EXPECT_EQ(s.p99_period_s, 3600.0);  // rank 99 is in the overflow bin
  EXPECT_EQ(s.max_period_s, 3600.0);
  EXPECT_EQ(s.overruns, 2u);
}

TEST(LoopTimingStatsTest, NonFiniteOrNegativePeriodsAreOnlyCountedAsRejected) {
  LoopTimingStats stats;
  stats.record(std::numeric_limits<double>::quiet_NaN(), true);
  stats.record(std::numeric_limits<double>::infinity(), true);
  stats.record(-1e-3, true);
  stats.record(2e-3, false);
  const LoopTimingSummary s = stats.summary();
  EXPECT_EQ(s.rejected, 3u);
  EXPECT_EQ(s.count, 1u);
  EXPECT_EQ(s.overruns, 0u);
  EXPECT_EQ(s.max_period_s, 2e-3);
}

TEST(LoopTimingStatsTest, ResetForgetsEverything) {
  LoopTimingStats stats;
  stats.record(5e-3, true);
  stats.reset();
  const LoopTimingSummary s = stats.summary();
  EXPECT_EQ(s.count, 0u);
  EXPECT_EQ(s.overruns, 0u);
  EXPECT_EQ(s.max_period_s, 0.0);
  EXPECT_EQ(s.p99_period_s, 0.0);
}

TEST(LoopTimingStatsTest, SummaryMayBeTakenWhileTheLoopRecords) {
  LoopTimingStats stats;
  constexpr int kCount = 200'000;
  std::thread loop([&] {
    for (int k = 0; k < kCount; ++k) stats.record((500.5 + k % 1000) * kUs, k % 100 == 0);
  });
  std::uint64_t last = 0;
  for (int polls = 0; polls < 20; ++polls) {
    const LoopTimingSummary s = stats.summary();
    EXPECT_GE(s.count, last);  // counts only grow
    if (s.count > 0) {
      EXPECT_GE(s.p50_period_s, 500.5 * kUs);
      EXPECT_LE(s.p99_period_s, s.max_period_s);
    }
    last = s.count;
  }
  loop.join();
  const LoopTimingSummary s = stats.summary();
  EXPECT_EQ(s.count, static_cast<std::uint64_t>(kCount));
  EXPECT_EQ(s.overruns, static_cast<std::uint64_t>(kCount / 100));
  EXPECT_EQ(s.max_period_s, 1499.5 * kUs);
  EXPECT_NEAR(s.p50_period_s, 999.5 * kUs, 1e-12);
}

}  // namespace
}  // namespace hapticlab
