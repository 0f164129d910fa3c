#pragma once
// Runs one simulated trial end to end: the sim device held by a simulated
// participant, the degradation engine, a simulated task VE and the haptic
// loop, with the virtual or the wall clock. Or, with a recording in
// `replay`, the replay device plays a recorded motion (no participant)
// through the engine and the VE: the same motion under another setting.
//
// The loop runs on its own thread; samples and events are handed to the
// caller's sink on the calling thread as they arrive. With the virtual
// clock the same configuration gives bit-identical samples.

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>

#include "core/device/device_spec.h"
#include "core/device/replay_device.h"
#include "core/device/sim_device.h"
#include "core/engine/engine.h"
#include "core/loop/haptic_loop.h"
#include "core/settings/settings.h"
#include "core/sim/participant.h"
#include "core/sim/population.h"
#include "core/sim/task_kind.h"
#include "core/loop/virtual_environment.h"

namespace hapticlab {

enum class ClockKind : std::uint8_t { kVirtual, kWall };
// "virtual" or "wall"; throws std::invalid_argument otherwise.
ClockKind parse_clock_kind(std::string_view name);

struct SimTrialConfig {
  TaskKind task = TaskKind::kDissection;
  // The device (device_spec.h). A simulated one (sim, or the simulated
  // workstation as a plugin or behind the UDP bridge) is held by a
  // simulated participant; any other is held by a person.
  DeviceSpec device;
  EngineSettings settings;
  std::uint64_t participant_seed = 1;  // who: the traits, drawn from `population`
  // The population simulated participants come from (population.h); the
  // default is the unfitted model, the commands read the fitted file.
  PopulationParams population;
  std::uint64_t trial_seed = 1;        // this trial: task layout and execution variation
  int practice_trials = 0;             // trials the participant already did
  // Those trials weighted by their force information, in [0,
  // practice_trials], and how much that weighting counts (practice.h).
  double force_informed_trials = 0.0;
  LearningModel learning;
  ClockKind clock = ClockKind::kVirtual;
  double rate_Hz = 1000.0;             // 150..2000
  bool thesis_rate = false;            // rate wanders 200..2000 Hz like the thesis' VE
  double max_duration_s = 300.0;
  bool stop_when_complete = true;       // false: run on to max_duration_s (benchmarks)
  bool publish_samples = true;         // false: no samples reach the sink (throughput runs)
  std::size_t sample_queue_capacity = 1 << 14;
  RealtimeOptions realtime;  // scheduling of the loop thread (core/loop/realtime.h)
  // Fault injection for tests: from this simulated time on, the device read
  // fails with this status. nullopt: no fault.
  std::optional<std::pair<DeviceStatus, double>> inject_fault;
  // Set: replay these frames (ReplayDevice) instead of the simulated device
  // and participant; the loop ends with StopReason::kEndOfData after the
  // last frame unless the task completes first (stop_when_complete) or
  // max_duration_s passes. participant_seed, practice_trials and
  // inject_fault are then unused; trial_seed still lays out the task.
  std::shared_ptr<const std::vector<ReplayFrame>> replay;
  // The loop's protections (docs/safety.md); force_limits carries the
  // protocol's "safety" object.
  LoopSafetyConfig safety;
};

struct SimTrialResult {
  StopReason stop_reason = StopReason::kNotStopped;
  DeviceStatus device_status = DeviceStatus::kOk;
  bool device_refused = false;  // activate() failed (device_status says why): nothing ran
  SafetyTrip safety_trip;       // stop_reason kSafetyLimit or kWatchdog: which limit
  bool task_complete = false;
  double duration_s = 0.0;          // loop time at the last update
  std::uint64_t samples = 0;
  std::uint64_t dropped_samples = 0;
  std::uint64_t dropped_events = 0;
  std::array<double, 2> peak_ve_force_N{0.0, 0.0};  // max |VE force| per instrument
  // The simulated participant's force information of this trial, in [0, 1]
  // (force_information.h); NaN without a simulated participant.
  double force_information = std::numeric_limits<double>::quiet_NaN();
  LoopTimingSummary timing;
  // SimTrialSink::device_hang_grace_s passed with a device call still not
  // returned after the watchdog halted the device: run_sim_trial gave up on
  // it. The rig was left to the loop's thread, which is inside the device's
  // code: the process must end without waiting for it (std::_Exit), and
  // must not open the device again meanwhile.
  bool device_hung = false;
  DeviceCall hung_call = DeviceCall::kNone;
  double hung_s = 0.0;  // how long the call had not returned when it was given up on [s]
};

// Everything one simulated trial needs, wired together and ready to run:
// the caller owns the loop's consumer side (a sink, or the database
// writer). Not movable: the parts point at each other.
class SimRig {
 public:
  // Throws std::invalid_argument (rate, durations, population) or SettingsError.
  explicit SimRig(const SimTrialConfig& config);
  SimRig(const SimRig&) = delete;
  SimRig& operator=(const SimRig&) = delete;
  ~SimRig();

  HapticLoop& loop() noexcept { return *loop_; }
  Device& device() noexcept { return *device_; }
  // The built-in simulated device; null when replaying or with another backend.
  SimDevice* sim_device() noexcept { return sim_device_; }
  // The simulated participant; null when replaying or with a device a person holds.
  const Participant* participant() const noexcept { return participant_.get(); }
  Engine& engine() noexcept { return *engine_; }
  VirtualEnvironment& ve() noexcept { return *ve_; }

 private:
  std::unique_ptr<Device> device_;
  SimDevice* sim_device_ = nullptr;  // device_ when it is the built-in simulated one
  HandAttachment* hand_ = nullptr;   // the device's, when a simulated participant holds it
  std::unique_ptr<Engine> engine_;
  std::unique_ptr<VirtualEnvironment> ve_;
  std::unique_ptr<Participant> participant_;
  std::unique_ptr<Clock> clock_;
  std::unique_ptr<HapticLoop> loop_;
};

struct SimTrialSink {
  std::function<void(const LoopSample&)> on_sample;
  std::function<void(const TaskEvent&)> on_event;
  // Called on the caller's thread after each drain while the loop runs
  // (every few hundred microseconds): the place to hand the engine new
  // settings (rig.engine().set_settings; they apply between two updates) or
  // to read the loop's timing. Returning false asks the loop to stop (zero
  // force, as any stop).
  std::function<bool(SimRig&)> between_drains;
  // > 0: once the loop's watchdog has tripped inside a device call
  // (HapticLoop::watchdog_tripped, watchdog_call), the call is waited for
  // this long [s]; then run_sim_trial returns with device_hung (above).
  // 0: waited for as long as it takes (a call that never returns then
  // keeps run_sim_trial from returning).
  double device_hang_grace_s = 0.0;
};

// Throws std::invalid_argument (rate, durations) or SettingsError before any
// simulation starts.
SimTrialResult run_sim_trial(const SimTrialConfig& config, const SimTrialSink& sink = {});

}  // namespace hapticlab
