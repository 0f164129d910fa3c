#pragma once
// The haptic loop: read device -> engine -> VE -> engine -> (participant) ->
// write device, once per update, on a dedicated thread.
//
// The engine steps its models on the device positions and returns the
// degraded positions; the VE steps on those; then the engine puts the VE's
// new tip force through the force side of its chains (Engine::
// refresh_forces), so the device displays it in the same update. Two cases
// keep the previous update's VE force instead (one update of VE latency):
// axes with backlash and inertia, whose virtual mass the VE force drives
// (the models step once per update, with the force they had), and the loop
// emulation of force latency or hold, which sets the VE force's timing
// itself.
//
// Real-time rules: after start() the loop thread does not allocate, lock or
// do I/O. Samples and events leave through lock-free single-producer queues
// whose capacity the caller sets; when a queue is full the item is dropped
// and counted (dropped_samples(), dropped_events()), never silently.
//
// Faults: a device read that fails or returns a non-finite value writes zero
// forces, records the fault and ends the loop (StopReason::kDeviceFault). A
// replay that runs out of recording (kEndOfData) ends it the same way but as
// StopReason::kEndOfData, with the device status left kOk.
//
// Safety (docs/safety.md, LoopSafetyConfig): every command passes the
// ForceGuard (ramp-in from zero at the loop's start, then the device's peak
// ratings and the operator's lower limits); every reading passes the
// ReadingGuard (range and velocity; a violation writes zero and ends the
// loop with StopReason::kSafetyLimit). On the wall clock a watchdog thread
// halts the device if the loop completes no update for watchdog_timeout_s,
// and an update that starts more than max_lateness_s late, or a sample
// queue that stays full for writer_stall_s, writes zero and ends the loop
// with StopReason::kWatchdog; when the stall was inside a device call (a
// read or write that did not return), the trip says which call
// (SafetyTripKind::kDeviceCallHung). An achieved rate outside the rate
// tolerance ends it with StopReason::kRateViolation. safety_trip() says
// which limit and by how much.
// A stop request is honoured at the start of an update and again just
// before its write, so at most the write already under way carries force.

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <thread>

#include "core/device/device.h"
#include "core/engine/engine.h"
#include "core/common/clock.h"
#include "core/loop/force_guard.h"
#include "core/loop/loop_sample.h"
#include "core/loop/loop_timing.h"
#include "core/loop/rate_monitor.h"
#include "core/loop/rate_schedule.h"
#include "core/loop/realtime.h"
#include "core/loop/reading_guard.h"
#include "core/loop/safety_trip.h"
#include "core/loop/spsc_queue.h"
#include "core/loop/watchdog.h"
#include "core/loop/task_event.h"
#include "core/loop/virtual_environment.h"

namespace hapticlab {

// How long the loop's last device calls as it ends (the zero-force write
// and deactivate()) may take together before the watchdog halts the device
// and names the call [s] (wall clock; docs/safety.md). Longer than an
// isolated plugin's own deactivate bound (2 s), which answers first.
inline constexpr double kShutdownCallLimit_s = 2.5;

enum class StopReason : std::uint8_t {
  kNotStopped = 0,
  kTaskComplete,    // the VE reported completion (after the linger time)
  kMaxDuration,     // LoopConfig::max_duration_s elapsed
  kStopRequested,   // request_stop() (operator abort, Ctrl-C)
  kDeviceFault,     // a device read or write failed, or returned non-finite values
  kEndOfData,       // a replay device ran out of recording: a normal end, not a fault
  kSafetyLimit,     // a reading outside the device's range or faster than its max velocity
  kWatchdog,        // the loop ran late, stalled, or its sample writer fell behind (wall clock)
  kRateViolation,   // the loop ran outside the rate tolerance (wall clock; LoopSafetyConfig::rate)
};
const char* to_string(StopReason reason) noexcept;

// The loop's protections (docs/safety.md). The last three act on the wall
// clock only: the virtual clock's time does not pass while the loop waits,
// so they could only fire spuriously and would break determinism.
struct LoopSafetyConfig {
  // Force ramp-in from the loop's start [s], 0..10 (0: none).
  double ramp_in_s = ForceGuard::kDefaultRampIn_s;
  OperatorForceLimits force_limits;  // the protocol's "safety" object
  // Readings may lie this fraction of a joint's span beyond its rated
  // range, 0..1 (ReadingGuard).
  double position_tolerance_fraction = ReadingGuard::kDefaultPositionToleranceFraction;
  // An update starting later than this after its deadline ends the loop
  // [s], 0.001..10. 20 ms: twenty missed updates at 1 kHz, three at the
  // slowest 150 Hz; a stiff virtual wall rendered that late already
  // pushes back with energy it should not have.
  double max_lateness_s = 0.020;
  // The watchdog thread halts the device when no update completes for this
  // long [s], 0.001..10, plus the device's read_timeout_s().
  double watchdog_timeout_s = 0.020;
  // A sample queue that stays full (samples dropped) this long ends the
  // loop [s], 0.001..60: the writer has stalled and the trial is no longer
  // recorded, which on a healthy host does not happen.
  double writer_stall_s = 0.25;
  // The achieved update rate must stay within rate.tolerance_fraction of
  // the schedule's over every window of rate.window_s (RateMonitor); else
  // zero force and StopReason::kRateViolation.
  RateCheck rate;
};
// Throws std::invalid_argument naming the field, the value and its range.
void validate(const LoopSafetyConfig& config);

struct LoopConfig {
  double max_duration_s = 600.0;       // > 0
  double linger_after_complete_s = 0.5;  // keep running (and logging) this long after completion
  std::size_t sample_queue_capacity = 1 << 14;  // LoopSamples buffered for the logger
  std::size_t event_queue_capacity = 1 << 12;   // TaskEvents buffered for the logger
  bool publish_samples = true;  // false: nothing is queued (benchmarks, planning)
  // With a virtual clock only: when a queue is full, wait for the consumer
  // instead of dropping (simulated time stands still meanwhile, so nothing
  // is distorted). Ignored with the wall clock, which never waits.
  bool wait_when_full_virtual = true;
  // Applied to the loop thread by start() (not by run(), whose thread is the
  // caller's); what it got is realtime_result().
  RealtimeOptions realtime;
  LoopSafetyConfig safety;
};

// What a simulated participant sees after the VE step of one update.
struct LoopTickView {
  double t_s;
  double dt_s;
  const DeviceReading& reading;
  const std::array<InstrumentOutput, 2>& engine;
  const VeInput& ve_input;
  const VeOutput& ve;
};

// Something that acts inside the loop besides device, engine and VE: the
// simulated participant. Called on the loop thread; must be real-time safe.
class LoopAgent {
 public:
  virtual ~LoopAgent() = default;
  virtual void act(const LoopTickView& view) noexcept = 0;
};

class HapticLoop {
 public:
  // All references must outlive the loop. The device must be configured;
  // the loop activates and deactivates it. Throws std::invalid_argument
  // for a LoopSafetyConfig out of range.
  HapticLoop(Device& device, Engine& engine, VirtualEnvironment& ve, Clock& clock,
             RateSchedule schedule, const LoopConfig& config, LoopAgent* agent = nullptr);
  ~HapticLoop();
  HapticLoop(const HapticLoop&) = delete;
  HapticLoop& operator=(const HapticLoop&) = delete;

  // Control thread: activates the device (amplifiers on, no force yet) and
  // takes its ratings for the guards, without starting the loop, so a
  // caller can check the device is ready (kNotCalibrated, ...) before it
  // records anything. Returns false if the device refuses; device_status()
  // tells why. start()/run() activate themselves unless this succeeded; a
  // loop activated and never started deactivates the device when destroyed.
  bool activate();
  // Runs the loop on a new thread. Returns false (and does not start) if the
  // device refuses to activate; device_status() tells why.
  bool start();
  // Runs the loop on the calling thread until it stops.
  StopReason run();
  void request_stop() noexcept { stop_requested_.store(true, std::memory_order_relaxed); }
  // Waits for the loop thread.
  void join();
  bool running() const noexcept { return running_.load(std::memory_order_acquire); }

  StopReason stop_reason() const noexcept { return stop_reason_.load(std::memory_order_acquire); }
  DeviceStatus device_status() const noexcept {
    return static_cast<DeviceStatus>(device_status_.load(std::memory_order_acquire));
  }
  std::uint64_t ticks() const noexcept { return ticks_.load(std::memory_order_relaxed); }
  double elapsed_s() const noexcept { return elapsed_s_.load(std::memory_order_relaxed); }
  std::uint64_t dropped_samples() const noexcept { return dropped_samples_.load(std::memory_order_relaxed); }
  std::uint64_t dropped_events() const noexcept { return dropped_events_.load(std::memory_order_relaxed); }
  LoopTimingSummary timing() const { return timing_.summary(); }
  // After join(): what LoopConfig::realtime got (all false when not asked).
  RealtimeResult realtime_result() const noexcept { return realtime_result_; }
  // Why kSafetyLimit or kWatchdog ended the loop; read once running() is false.
  const SafetyTrip& safety_trip() const noexcept { return trip_; }
  // Once running() is false: what the loop's last device calls answered --
  // the zero-force write and deactivate() -- and which failed (kNone: both
  // kOk). A failure means the device may still be powered.
  DeviceStatus shutdown_status() const noexcept { return shutdown_status_; }
  DeviceCall shutdown_call() const noexcept { return shutdown_call_; }
  // Command entries the force limits (not the ramp) changed so far.
  std::uint64_t limited_commands() const noexcept { return limited_commands_.load(std::memory_order_relaxed); }
  // The guard the commands pass; valid after activate().
  const ForceGuard& force_guard() const noexcept { return force_guard_; }
  // Any thread, while the loop runs: the watchdog has halted the device
  // because the loop completed no update for watchdog_timeout_s, and which
  // device call the loop was in then (kNone: elsewhere). The loop may still
  // be stuck in that call.
  bool watchdog_tripped() const noexcept { return watchdog_ && watchdog_->tripped(); }
  DeviceCall watchdog_call() const noexcept { return watchdog_ ? watchdog_->call() : DeviceCall::kNone; }
  // After watchdog_tripped(): the limit that applied [s] (watchdog_timeout_s,
  // plus the device's own read timeout when the loop was in a read).
  double watchdog_limit_s() const noexcept {
    return watchdog_ ? watchdog_->tripped_limit_s() : config_.safety.watchdog_timeout_s;
  }
  // Any thread: the device call the loop thread is in now (a crash handler
  // reads it), and the loop thread's kernel thread id (0 before it runs).
  const std::atomic<DeviceCall>& device_call() const noexcept { return device_call_; }
  int loop_thread_id() const noexcept { return loop_tid_.load(std::memory_order_acquire); }

  // Consumer side of the queues (one consumer thread).
  SpscQueue<LoopSample>& samples() noexcept { return samples_; }
  SpscQueue<TaskEvent>& events() noexcept { return events_; }

 private:
  void start_watchdog();
  StopReason loop_body();
  void finish(StopReason reason) noexcept;
  StopReason trip(StopReason reason, const SafetyTrip& why) noexcept;
  bool lateness_trips(double late_s) const noexcept;
  template <typename T>
  void push_or_count(SpscQueue<T>& queue, const T& item, bool wait,
                     std::atomic<std::uint64_t>& dropped) noexcept;

  Device& device_;
  Engine& engine_;
  VirtualEnvironment& ve_;
  Clock& clock_;
  RateSchedule schedule_;
  LoopConfig config_;
  LoopAgent* agent_;

  SpscQueue<LoopSample> samples_;
  SpscQueue<TaskEvent> events_;
  LoopTimingStats timing_;
  std::thread thread_;
  RealtimeResult realtime_result_;  // written by the loop thread, read after join()
  ForceGuard force_guard_;
  ReadingGuard reading_guard_;
  SafetyTrip trip_;
  std::unique_ptr<Watchdog> watchdog_;
  bool activated_ = false;  // control thread: activate() succeeded, loop not yet run

  std::atomic<DeviceCall> device_call_{DeviceCall::kNone};
  DeviceStatus shutdown_status_ = DeviceStatus::kOk;  // written before running_ turns false
  DeviceCall shutdown_call_ = DeviceCall::kNone;
  std::atomic<int> loop_tid_{0};
  std::atomic<bool> stop_requested_{false};
  std::atomic<bool> running_{false};
  std::atomic<StopReason> stop_reason_{StopReason::kNotStopped};
  std::atomic<std::int32_t> device_status_{0};
  std::atomic<std::uint64_t> ticks_{0};
  std::atomic<double> elapsed_s_{0.0};
  std::atomic<std::uint64_t> dropped_samples_{0};
  std::atomic<std::uint64_t> dropped_events_{0};
  std::atomic<std::uint64_t> limited_commands_{0};
};

}  // namespace hapticlab
