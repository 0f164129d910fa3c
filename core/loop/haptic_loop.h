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

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <thread>

#include "core/device/device.h"
#include "core/engine/engine.h"
#include "core/loop/clock.h"
#include "core/loop/loop_sample.h"
#include "core/loop/loop_timing.h"
#include "core/loop/rate_schedule.h"
#include "core/loop/realtime.h"
#include "core/loop/spsc_queue.h"
#include "core/sim/task_event.h"
#include "core/sim/virtual_environment.h"

namespace hapticlab {

enum class StopReason : std::uint8_t {
  kNotStopped = 0,
  kTaskComplete,    // the VE reported completion (after the linger time)
  kMaxDuration,     // LoopConfig::max_duration_s elapsed
  kStopRequested,   // request_stop() (operator abort, Ctrl-C)
  kDeviceFault,     // a device read or write failed, or returned non-finite values
  kEndOfData,       // a replay device ran out of recording: a normal end, not a fault
};
const char* to_string(StopReason reason) noexcept;

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
  // the loop activates and deactivates it.
  HapticLoop(Device& device, Engine& engine, VirtualEnvironment& ve, Clock& clock,
             RateSchedule schedule, const LoopConfig& config, LoopAgent* agent = nullptr);
  ~HapticLoop();
  HapticLoop(const HapticLoop&) = delete;
  HapticLoop& operator=(const HapticLoop&) = delete;

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

  // Consumer side of the queues (one consumer thread).
  SpscQueue<LoopSample>& samples() noexcept { return samples_; }
  SpscQueue<TaskEvent>& events() noexcept { return events_; }

 private:
  bool activate();
  StopReason loop_body();
  void finish(StopReason reason) noexcept;
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

  std::atomic<bool> stop_requested_{false};
  std::atomic<bool> running_{false};
  std::atomic<StopReason> stop_reason_{StopReason::kNotStopped};
  std::atomic<std::int32_t> device_status_{0};
  std::atomic<std::uint64_t> ticks_{0};
  std::atomic<double> elapsed_s_{0.0};
  std::atomic<std::uint64_t> dropped_samples_{0};
  std::atomic<std::uint64_t> dropped_events_{0};
};

}  // namespace hapticlab
