// StallCounter on made-up clock reads, worked by hand; probe_stalls on the
// real clock only for what holds on any machine.
#include "core/loop/stall_probe.h"

#include <gtest/gtest.h>

namespace hapticlab {
namespace {

TEST(StallCounterTest, ReadsEvery10UsHaveNoStall) {
  StallCounter c(100e-6);
  for (int k = 0; k <= 1000; ++k) c.add(k * 10e-6);  // 0 .. 10 ms
  // Windows 0..9 complete (the read at exactly 10 ms opens window 10).
  EXPECT_EQ(c.result().windows, 10u);
  EXPECT_EQ(c.result().windows_with_stall, 0u);
  EXPECT_NEAR(c.result().max_stall_s, 10e-6, 1e-12);
}

TEST(StallCounterTest, AStallCountsOnceInTheWindowWhereItEnds) {
  StallCounter c(100e-6);
  double t = 0.0;
  for (; t < 2.5e-3; t += 10e-6) c.add(t);  // windows 0, 1, half of 2
  t = 2.7e-3;                               // a 200 µs stall ends in window 2
  c.add(t);
  for (t += 10e-6; t < 3.0e-3; t += 10e-6) c.add(t);
  t = 5.45e-3;                              // a ~2.46 ms stall: windows 3, 4 skipped, ends in 5
  c.add(t);
  for (t += 10e-6; t < 8.0e-3; t += 10e-6) c.add(t);
  // Completed: 0, 1, 2 (stall), 5 (stall), 6; window 7 is still open.
  EXPECT_EQ(c.result().windows, 5u);
  EXPECT_EQ(c.result().windows_with_stall, 2u);
  EXPECT_NEAR(c.result().max_stall_s, 5.45e-3 - 2.99e-3, 2e-5);
  EXPECT_NEAR(c.result().stalled_fraction(), 2.0 / 5.0, 1e-15);
}

TEST(StallCounterTest, AGapAtTheThresholdIsNotAStall) {
  StallCounter c(100e-6);
  c.add(0.0);
  c.add(0.25e-3);  // 250 µs: a stall in window 0
  c.add(0.35e-3);  // exactly 100 µs: not one
  c.add(1.05e-3);  // 700 µs, ends in window 1
  c.add(2.0e-3);
  EXPECT_EQ(c.result().windows, 2u);
  EXPECT_EQ(c.result().windows_with_stall, 2u);
  StallCounter d(1e-3);
  d.add(0.0);
  d.add(0.9e-3);
  d.add(1.1e-3);
  EXPECT_EQ(d.result().windows, 1u);
  EXPECT_EQ(d.result().windows_with_stall, 0u);
}

TEST(StallProbeTest, SpinsForTheDurationAndSeesEveryWindow) {
  // 50 ms of spinning: at most 50 complete windows, and at least 10 even on
  // a busy machine (windows a stall skips whole are not counted); a stall
  // can never be longer than the run.
  const StallProbeResult r = probe_stalls(0.05);
  EXPECT_GE(r.windows, 10u);
  EXPECT_LE(r.windows, 50u);
  EXPECT_LE(r.windows_with_stall, r.windows);
  EXPECT_GT(r.max_stall_s, 0.0);
  EXPECT_LT(r.max_stall_s, 0.05 + 1e-3);
}

}  // namespace
}  // namespace hapticlab
