#include "core/sim/trial_runner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "core/device/device_factory.h"
#include "core/device/sim_device.h"
#include "core/engine/engine.h"
#include "core/common/clock.h"
#include "core/sim/clip_task.h"
#include "core/sim/dissection_task.h"

namespace hapticlab {

ClockKind parse_clock_kind(std::string_view name) {
  if (name == "virtual") return ClockKind::kVirtual;
  if (name == "wall") return ClockKind::kWall;
  throw std::invalid_argument("clock: '" + std::string(name) + "' is not a clock; choose virtual or wall");
}

namespace {

// The fields SimRig checks itself (the rate, the population and the device
// are checked where they are used).
void check_trial_config(const SimTrialConfig& config) {
  if (!(config.max_duration_s > 0.0) || !std::isfinite(config.max_duration_s))
    throw std::invalid_argument("max_duration_s: " + std::to_string(config.max_duration_s) +
                                " must be a positive number of seconds");
  config.learning.validate();
  if (!(config.force_informed_trials >= 0.0 && config.force_informed_trials <= config.practice_trials))
    throw std::invalid_argument("force_informed_trials: " + std::to_string(config.force_informed_trials) +
                                " must be within 0..practice_trials (" + std::to_string(config.practice_trials) + ")");
}

}  // namespace

SimRig::SimRig(const SimTrialConfig& config) {
  check_trial_config(config);
  RateSchedule schedule = config.thesis_rate ? RateSchedule::thesis_wander(config.trial_seed)
                                             : RateSchedule::fixed(config.rate_Hz);

  std::array<JointVector, kNumInstruments> start{};
  const auto set_start = [&](int i, const DeviceJoints& pose) {
    start[static_cast<std::size_t>(i)] = JointVector(pose[kJointInsertion], pose[kJointPitch], pose[kJointYaw]);
  };
  if (config.replay) {
    if (config.replay->empty()) throw std::invalid_argument("replay: the recording has no frames");
    // Throws std::invalid_argument naming a bad frame.
    device_ = std::make_unique<ReplayDevice>(*config.replay);
    for (int i = 0; i < 2; ++i) set_start(i, config.replay->front().position[static_cast<std::size_t>(i)]);
  } else {
    device_ = open_device(config.device);
    hand_ = device_->hand_attachment();
    sim_device_ = dynamic_cast<SimDevice*>(device_.get());
  }
  DeviceConfig device_config;
  device_config.nominal_rate_Hz = std::clamp(1.0 / schedule.nominal_period_s(), 150.0, 2000.0);
  device_config.seed = config.trial_seed;
  if (const DeviceStatus status = device_->configure(device_config); status != DeviceStatus::kOk)
    throw std::invalid_argument("device: the " + std::string(device_->name()) + " device refused its configuration (" +
                                to_string(status) + ") at rate_Hz " + std::to_string(device_config.nominal_rate_Hz));
  if (!config.replay) {
    // A simulated participant holds a simulated device at its start pose;
    // a real one is where the person left it, and the engine re-anchors on
    // the first reading.
    for (int i = 0; i < 2; ++i) {
      const DeviceJoints pose = Participant::start_pose(i);
      if (hand_ != nullptr && !hand_->set_start_pose(i, pose))
        throw std::runtime_error("device: the " + config.device.describe() + " device refused the start pose");
      set_start(i, pose);
    }
  }
  if (config.inject_fault && sim_device_ != nullptr)
    sim_device_->inject_fault(config.inject_fault->first, config.inject_fault->second);

  engine_ = std::make_unique<Engine>(config.settings, start);
  const DissectionTask* dissection = nullptr;
  const ClipTask* clip = nullptr;
  if (config.task == TaskKind::kDissection) {
    auto task = std::make_unique<DissectionTask>(config.trial_seed);
    dissection = task.get();
    ve_ = std::move(task);
  } else {
    auto task = std::make_unique<ClipTask>(config.trial_seed);
    clip = task.get();
    ve_ = std::move(task);
  }

  if (hand_ != nullptr) {
    config.population.validate();
    const ParticipantTraits traits = ParticipantTraits::sample(config.participant_seed, config.population);
    const ParticipantTrial trial{config.trial_seed, config.practice_trials, config.force_informed_trials,
                                 config.learning};
    participant_ = dissection != nullptr ? std::make_unique<Participant>(traits, trial, *hand_, *dissection)
                                         : std::make_unique<Participant>(traits, trial, *hand_, *clip);
  }

  if (config.clock == ClockKind::kVirtual) clock_ = std::make_unique<VirtualClock>();
  else clock_ = std::make_unique<WallClock>();
  LoopConfig loop_config;
  loop_config.max_duration_s = config.max_duration_s;
  // On the virtual clock the loop waits for the consumer instead of
  // dropping, so a short queue loses nothing; it saves zeroing megabytes per
  // trial, a noticeable share of a simulated trial's cost.
  loop_config.sample_queue_capacity = config.clock == ClockKind::kVirtual
                                          ? std::min<std::size_t>(config.sample_queue_capacity, 1 << 11)
                                          : config.sample_queue_capacity;
  loop_config.publish_samples = config.publish_samples;
  loop_config.realtime = config.realtime;
  loop_config.safety = config.safety;
  if (!config.stop_when_complete) loop_config.linger_after_complete_s = config.max_duration_s;
  loop_ = std::make_unique<HapticLoop>(*device_, *engine_, *ve_, *clock_, std::move(schedule),
                                       loop_config, participant_.get());
}

SimRig::~SimRig() {
  if (loop_) {
    loop_->request_stop();
    loop_->join();
  }
}

// The drain takes at most 64 batches before sink.between_drains is asked
// again: on the virtual clock the loop refills the queue as fast as it is
// popped (it waits rather than drops), so draining "until empty" lasted the
// whole trial and a stop (STOP, Ctrl-C) was first seen after its end.
SimTrialResult run_sim_trial(const SimTrialConfig& config, const SimTrialSink& sink) {
  // On the heap: a device call that never returns keeps the loop thread
  // inside the rig, which then can never be destroyed (device_hung).
  auto rig_owner = std::make_unique<SimRig>(config);
  SimRig& rig = *rig_owner;
  HapticLoop& loop = rig.loop();
  SimTrialResult result;
  std::vector<LoopSample> batch(256);
  // Samples first, then events: an event is queued before the sample of its
  // update, so after this order every event up to the last popped sample is
  // in hand and the sink gets events no later than their sample.
  // At most 64 batches per call (see above); returns whether it emptied the queue.
  auto drain = [&]() -> bool {
    for (int round = 0; round < 64; ++round) {
      const std::size_t n = loop.samples().pop_bulk(batch.data(), batch.size());
      TaskEvent event;
      while (loop.events().try_pop(event))
        if (sink.on_event) sink.on_event(event);
      if (n == 0) return true;
      for (std::size_t k = 0; k < n; ++k) {
        const LoopSample& s = batch[k];
        for (int i = 0; i < 2; ++i) {
          const auto& f = s.instrument[static_cast<std::size_t>(i)].ve_force_N;
          auto& peak = result.peak_ve_force_N[static_cast<std::size_t>(i)];
          peak = std::max(peak, std::sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]));
        }
        if (sink.on_sample) sink.on_sample(s);
      }
      result.samples += n;
    }
    return false;
  };

  if (!loop.start()) {
    result.stop_reason = loop.stop_reason();
    result.device_status = loop.device_status();
    result.device_refused = true;
    return result;
  }
  std::optional<std::chrono::steady_clock::time_point> hung_since;
  while (loop.running()) {
    const bool emptied = drain();
    if (sink.between_drains && !sink.between_drains(rig)) loop.request_stop();
    if (sink.device_hang_grace_s > 0.0 && loop.watchdog_tripped() && loop.watchdog_call() != DeviceCall::kNone) {
      const auto now = std::chrono::steady_clock::now();
      if (!hung_since) hung_since = now;
      const double waited_s = std::chrono::duration<double>(now - *hung_since).count();
      if (waited_s > sink.device_hang_grace_s) {
        result.device_hung = true;
        result.hung_call = loop.watchdog_call();
        result.hung_s = waited_s + loop.watchdog_limit_s();
        result.stop_reason = loop.stop_reason();
        result.device_status = loop.device_status();
        result.safety_trip = loop.safety_trip();
        result.duration_s = loop.elapsed_s();
        result.dropped_samples = loop.dropped_samples();
        result.dropped_events = loop.dropped_events();
        result.timing = loop.timing();
        (void)rig_owner.release();  // the loop's thread is still inside the device's code
        return result;
      }
    }
    if (emptied) std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  loop.join();
  while (!drain()) continue;

  result.stop_reason = loop.stop_reason();
  result.device_status = loop.device_status();
  result.safety_trip = loop.safety_trip();
  result.task_complete = rig.ve().complete();
  if (rig.participant() != nullptr) result.force_information = rig.participant()->force_information();
  result.duration_s = loop.elapsed_s();
  result.dropped_samples = loop.dropped_samples();
  result.dropped_events = loop.dropped_events();
  result.timing = loop.timing();
  return result;
}

}  // namespace hapticlab
