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

TEST(SignalDelayHoldTest, FasterUpdatesThanTheBufferCoversShortenTheLatency) {
  SignalDelayHold d;
  d.reset(v(0));
  // 100 ms at 10 kHz would need 1000 samples; the buffer keeps 256.
  Eigen::Vector3d out;
  for (int i = 1; i <= 2000; ++i) out = d.step(v(i), 1e-4, 0.1, 0.0);
  EXPECT_EQ(out, v(2000 - SignalDelayHold::kCapacity + 1));
}

}  // namespace
}  // namespace hapticlab
