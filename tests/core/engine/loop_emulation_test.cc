#include "core/engine/loop_emulation.h"

#include <gtest/gtest.h>

namespace hapticlab {
namespace {

Eigen::Vector3d v(double x) { return {x, 2 * x, -x}; }

TEST(SignalDelayHoldTest, OffPassesThrough) {
  SignalDelayHold d;
  d.reset(v(0));
  for (int i = 1; i < 10; ++i) EXPECT_EQ(d.step(v(i), 1e-3, 0.0, 0.0), v(i));
}

TEST(SignalDelayHoldTest, LatencyDelaysByWholeUpdates) {
  SignalDelayHold d;
  d.reset(v(0));
  // 10 ms at 1 kHz: the output is the input of 10 updates earlier.
  for (int i = 1; i < 100; ++i) {
    const Eigen::Vector3d out = d.step(v(i), 1e-3, 0.010, 0.0);
    EXPECT_EQ(out, v(i >= 10 ? i - 10 : 0)) << i;
  }
}

TEST(SignalDelayHoldTest, HoldUpdatesAtTheEmulatedRate) {
  SignalDelayHold d;
  d.reset(v(0));
  // A 100 Hz loop emulated inside a 1 kHz one: a new value every 10 updates.
  int changes = 0;
  Eigen::Vector3d last = v(0);
  for (int i = 1; i <= 100; ++i) {
    const Eigen::Vector3d out = d.step(v(i), 1e-3, 0.0, 100.0);
    if (out != last) ++changes;
    last = out;
  }
  EXPECT_EQ(changes, 10);
}

TEST(SignalDelayHoldTest, FasterUpdatesThanTheBufferCoversKeepTheWholeLatency) {
  // 100 ms at 10 and 32 kHz would need 1000 and 3200 samples; the buffer
  // keeps 256, at least 0.4 ms apart (so less than 0.4 ms plus one update),
  // and the delay is the latency plus less than that (it was cut to 25.6 ms
  // at 10 kHz when every sample was kept).
  for (const double rate_Hz : {10000.0, 32000.0, 4000.0}) {
    SignalDelayHold d;
    d.reset(v(0));
    const double dt_s = 1.0 / rate_Hz;
    const int n = static_cast<int>(0.5 * rate_Hz);  // 0.5 s
    Eigen::Vector3d out = v(0);
    for (int i = 1; i <= n; ++i) out = d.step(v(i), dt_s, 0.1, 0.0);
    // The input of update i was given at i·dt; the output's age in updates.
    const double age_s = (n - out.x()) * dt_s;
    EXPECT_GE(age_s, 0.1 - 1e-9) << rate_Hz;
    EXPECT_LT(age_s, 0.1 + SignalDelayHold::kMinSpacing_s + dt_s) << rate_Hz;
  }
}

TEST(SignalDelayHoldTest, UpTo2500HzEveryUpdatesSampleIsKept) {
  // At 2.5 kHz (the closest kept spacing) a latency of 25.5 updates
  // (10.2 ms, half an update from either whole number, so the accumulated
  // times' rounding cannot decide it) delivers every input 26 updates late:
  // none is skipped.
  SignalDelayHold d;
  d.reset(v(0));
  for (int i = 1; i < 2000; ++i) {
    const Eigen::Vector3d out = d.step(v(i), 1.0 / 2500.0, 0.0102, 0.0);
    EXPECT_EQ(out, v(i >= 26 ? i - 26 : 0)) << i;
  }
}

}  // namespace
}  // namespace hapticlab
