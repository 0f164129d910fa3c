#pragma once
// FakeDevice: a Device that misbehaves on cue, for the safety tests. It is
// driven by the real HapticLoop (on the wall clock where timing matters)
// and records every command it is given, when, and every halt(), from
// which thread, so a test checks what reached the "motors", not a flag.
//
// Pose: a slow, in-range motion (0.2 rad/s at most on any joint) around
// insertion 0.10 m, pitch 0.1, yaw −0.1, twist 0, grip 0.2 rad. Cues, each
// by read number (0-based; -1 = never):
//   stall_at_read        that read sleeps stall_s, then answers normally
//   write_delay_s        every write sleeps this long first
//   nan_at_read          instrument 0's grip reads NaN (status kOk)
//   jump_from_read       instrument 1's insertion reads 1 m further out
//   fast_from_read       instrument 0's pitch moves fast_rad_per_read more per read
//   timeout_from_read    the device stops answering: kTimeout, reading untouched
// and activate_status for the activation (kNotCalibrated, ...).
//
// Threads: the cues and `ratings_override` are set before the loop starts;
// read/write on the loop thread; halt() from any thread; writes() and
// halt details after the loop has ended; write_count() at any time.
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <thread>
#include <vector>

#include "core/device/device.h"

namespace hapticlab::testing {

class FakeDevice final : public Device {
 public:
  using Steady = std::chrono::steady_clock;

  FakeDevice() {
    writes_.reserve(kMaxWrites);
    write_times_.reserve(kMaxWrites);
  }

  static DeviceJoints pose(int instrument, int n) {
    const double s = 0.001 * n;  // rad/s-scale motion at a 1 kHz read rate
    return {0.10 + 0.01 * std::sin(s + instrument), 0.1 + 0.1 * std::sin(s), -0.1 + 0.1 * std::cos(s), 0.0,
            0.2 + 0.05 * std::sin(s)};
  }

  DeviceStatus configure(const DeviceConfig&) override { return DeviceStatus::kOk; }
  DeviceStatus activate(const Clock&) override {
    ++activations;
    reads_.store(0);
    return activate_status;
  }
  DeviceStatus read(DeviceReading& reading) noexcept override {
    loop_thread_.store(std::this_thread::get_id());
    const int n = reads_.fetch_add(1);
    if (n == stall_at_read) {
      writes_before_stall = write_count();
      stall_started = Steady::now();
      std::this_thread::sleep_for(std::chrono::duration<double>(stall_s));
      stall_ended = Steady::now();
    }
    if (timeout_from_read >= 0 && n >= timeout_from_read) return DeviceStatus::kTimeout;
    for (int i = 0; i < 2; ++i) reading.position[static_cast<std::size_t>(i)] = pose(i, n);
    if (n == nan_at_read) reading.position[0][kJointGrip] = std::numeric_limits<double>::quiet_NaN();
    if (jump_from_read >= 0 && n >= jump_from_read) reading.position[1][kJointInsertion] += 1.0;
    if (fast_from_read >= 0 && n >= fast_from_read)
      reading.position[0][kJointPitch] += fast_rad_per_read * (n - fast_from_read + 1);
    return DeviceStatus::kOk;
  }
  DeviceStatus write(const DeviceCommand& command) noexcept override {
    if (write_delay_s > 0.0) std::this_thread::sleep_for(std::chrono::duration<double>(write_delay_s));
    if (writes_.size() < kMaxWrites) {  // reserved: never reallocates on the loop thread
      writes_.push_back(command);
      write_times_.push_back(Steady::now());
    }
    write_count_.store(writes_.size(), std::memory_order_release);
    return DeviceStatus::kOk;
  }
  DeviceStatus deactivate() noexcept override {
    ++deactivations;
    return DeviceStatus::kOk;
  }
  void halt() noexcept override {
    halt_thread_.store(std::this_thread::get_id());
    halt_time_ns_.store(Steady::now().time_since_epoch().count());
    halts.fetch_add(1);
  }
  // As an isolated plugin's frozen host: the halt is never confirmed.
  bool halt_unconfirmed() const noexcept override { return halt_never_confirmed && halts.load() > 0; }
  const char* name() const noexcept override { return "fake"; }
  double read_timeout_s() const noexcept override { return read_timeout; }
  DeviceRatings ratings() const noexcept override { return ratings_override.value_or(workstation_ratings()); }

  // --- what happened
  std::size_t write_count() const noexcept { return write_count_.load(std::memory_order_acquire); }
  const std::vector<DeviceCommand>& writes() const noexcept { return writes_; }
  const std::vector<Steady::time_point>& write_times() const noexcept { return write_times_; }
  int reads() const noexcept { return reads_.load(); }
  std::thread::id loop_thread() const noexcept { return loop_thread_.load(); }
  std::thread::id halt_thread() const noexcept { return halt_thread_.load(); }
  Steady::time_point halt_time() const noexcept {
    return Steady::time_point(Steady::duration(halt_time_ns_.load()));
  }

  // --- cues
  DeviceStatus activate_status = DeviceStatus::kOk;
  int stall_at_read = -1;
  double stall_s = 0.1;
  double write_delay_s = 0.0;  // every write takes this long (a device on a slow bus)
  double read_timeout = 0.0;   // what read_timeout_s() says (a bridge's own wait for an answer)
  int nan_at_read = -1;
  int jump_from_read = -1;
  int fast_from_read = -1;
  double fast_rad_per_read = 0.0;
  int timeout_from_read = -1;
  bool halt_never_confirmed = false;
  std::optional<DeviceRatings> ratings_override;

  // --- counters and stall times (the stall's are written on the loop thread
  // before the loop ends: read them after it has)
  int activations = 0;
  int deactivations = 0;
  std::atomic<int> halts{0};
  std::size_t writes_before_stall = 0;
  Steady::time_point stall_started{}, stall_ended{};

 private:
  static constexpr std::size_t kMaxWrites = 1 << 16;
  std::vector<DeviceCommand> writes_;
  std::vector<Steady::time_point> write_times_;
  std::atomic<std::size_t> write_count_{0};
  std::atomic<int> reads_{0};
  std::atomic<std::thread::id> loop_thread_{};
  std::atomic<std::thread::id> halt_thread_{};
  std::atomic<Steady::rep> halt_time_ns_{0};
};

inline bool all_zero(const DeviceCommand& c) {
  for (const auto& joints : c.force)
    for (double f : joints)
      if (f != 0.0) return false;
  return true;
}

}  // namespace hapticlab::testing
