#pragma once
// Watchdog: a thread of its own that watches the haptic loop's heartbeat (a
// counter the loop advances once per completed update) and, if it has not
// moved for longer than timeout_s, calls Device::halt() from that thread —
// the force is cut while the loop itself is still stuck (a device read that
// hangs, a VE step that stalls), not once it comes back. It halts once per
// start(); tripped() and stalled_for_s() tell the loop afterwards.
//
// Wall clock only: on the virtual clock the loop may wait for a slow
// consumer by design, and simulated time does not pass meanwhile.
//
// The thread checks every timeout_s / 4 (at least every 1 ms), so it halts
// between timeout_s and 1.25·timeout_s after the last completed update
// (plus the read allowance while the loop is in a device read), plus
// whatever the OS delays the watchdog thread itself.
//
// Threads: start(), stop() and the destructor on the control thread;
// disarm() from any thread (the loop, as it ends) without locking;
// tripped()/stalled_for_s() from any thread. Not copyable or movable.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>

#include "core/device/device.h"
#include "core/loop/safety_trip.h"

namespace hapticlab {

class Watchdog {
 public:
  // timeout_s > 0. `heartbeat`, `device` and `call` (the device call the
  // loop is in, if it says; may be null) must outlive the watchdog.
  // read_allowance_s >= 0 is added to the timeout while the loop is inside
  // a device read, and only then: a device that waits for its answer up to
  // its own timeout (the UDP bridge's timeout_ms) names its own silence
  // (device_timeout), while a stall anywhere else is still cut after
  // timeout_s.
  Watchdog(const std::atomic<std::uint64_t>& heartbeat, Device& device, double timeout_s,
           const std::atomic<DeviceCall>* call = nullptr, double read_allowance_s = 0.0) noexcept;
  ~Watchdog();
  Watchdog(const Watchdog&) = delete;
  Watchdog& operator=(const Watchdog&) = delete;

  // Arms and starts the thread; the heartbeat counts as fresh now.
  void start();
  // Stops and joins the thread. Safe to call twice or without start().
  void stop() noexcept;
  // No halt from now on (the loop ended by itself).
  void disarm() noexcept { armed_.store(false, std::memory_order_release); }
  // The loop's last device calls as it ends (the zero-force write,
  // deactivate()): watched for `limit_s` from now instead of the heartbeat,
  // armed again even if the watchdog already halted once (the call it then
  // names replaces the earlier one), so a call that never returns is found
  // and named. disarm() after them.
  void watch_shutdown(double limit_s) noexcept;
  // It halted during those last calls (they took longer than limit_s).
  bool shutdown_tripped() const noexcept { return shutdown_tripped_.load(std::memory_order_acquire); }

  bool tripped() const noexcept { return tripped_.load(std::memory_order_acquire); }
  // How long the heartbeat had not moved when the watchdog halted [s].
  double stalled_for_s() const noexcept { return stalled_for_s_.load(std::memory_order_acquire); }
  double timeout_s() const noexcept { return timeout_s_; }
  // The limit that applied when it halted: timeout_s, plus the read
  // allowance if the loop was in a read.
  double tripped_limit_s() const noexcept { return tripped_limit_s_.load(std::memory_order_acquire); }
  // The device call the loop was in when the watchdog halted (kNone: not in one).
  DeviceCall call() const noexcept { return tripped_call_.load(std::memory_order_acquire); }

 private:
  void watch();

  const std::atomic<std::uint64_t>& heartbeat_;
  Device& device_;
  double timeout_s_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;  // under mutex_
  std::atomic<bool> armed_{false};
  std::atomic<bool> tripped_{false};
  std::atomic<double> stalled_for_s_{0.0};
  const std::atomic<DeviceCall>* call_;
  double read_allowance_s_;
  std::atomic<DeviceCall> tripped_call_{DeviceCall::kNone};
  std::atomic<double> tripped_limit_s_{0.0};
  std::atomic<double> shutdown_limit_s_{0.0};
  std::atomic<std::int64_t> shutdown_since_ns_{0};  // steady clock; 0: not shutting down
  std::atomic<bool> shutdown_tripped_{false};
};

}  // namespace hapticlab
