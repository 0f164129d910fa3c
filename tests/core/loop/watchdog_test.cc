// Watchdog: halts from its own thread once the heartbeat stops, not while
// it beats, and not once disarmed.
#include "core/loop/watchdog.h"

#include <atomic>
#include <chrono>
#include <thread>

#include <gtest/gtest.h>

#include "tests/testing/fake_device.h"

namespace hapticlab {
namespace {

using namespace std::chrono_literals;
using testing::FakeDevice;

TEST(WatchdogTest, HaltsOnceFromItsOwnThreadWhenTheHeartbeatStops) {
  std::atomic<std::uint64_t> heartbeat{0};
  FakeDevice device;
  Watchdog watchdog(heartbeat, device, 0.020);
  const auto started = FakeDevice::Steady::now();
  watchdog.start();
  std::this_thread::sleep_for(150ms);
  watchdog.stop();
  ASSERT_EQ(device.halts.load(), 1);
  EXPECT_NE(device.halt_thread(), std::this_thread::get_id());
  const double after_s = std::chrono::duration<double>(device.halt_time() - started).count();
  EXPECT_GE(after_s, 0.020);
  EXPECT_LT(after_s, 0.150);  // 1.25 × timeout (25 ms) plus generous scheduling room
  EXPECT_TRUE(watchdog.tripped());
  EXPECT_GE(watchdog.stalled_for_s(), 0.020);
}

TEST(WatchdogTest, ABeatingHeartOrADisarmedWatchdogIsLeftAlone) {
  std::atomic<std::uint64_t> heartbeat{0};
  FakeDevice device;
  Watchdog watchdog(heartbeat, device, 0.020);
  watchdog.start();
  for (int k = 0; k < 80; ++k) {  // 80 ms of 1 ms beats
    heartbeat.fetch_add(1);
    std::this_thread::sleep_for(1ms);
  }
  EXPECT_EQ(device.halts.load(), 0);
  watchdog.disarm();
  std::this_thread::sleep_for(60ms);  // stopped beating, but disarmed
  watchdog.stop();
  EXPECT_EQ(device.halts.load(), 0);
  EXPECT_FALSE(watchdog.tripped());
}

}  // namespace
}  // namespace hapticlab
