#include "core/loop/haptic_loop.h"

#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>

#include "core/loop/workspace.h"

namespace hapticlab {

const char* to_string(StopReason reason) noexcept {
  switch (reason) {
    case StopReason::kNotStopped: return "not_stopped";
    case StopReason::kTaskComplete: return "task_complete";
    case StopReason::kMaxDuration: return "max_duration";
    case StopReason::kStopRequested: return "stop_requested";
    case StopReason::kDeviceFault: return "device_fault";
    case StopReason::kEndOfData: return "end_of_data";
    case StopReason::kSafetyLimit: return "safety_limit";
    case StopReason::kWatchdog: return "watchdog";
    case StopReason::kRateViolation: return "rate_violation";
  }
  return "unknown";
}

namespace {

void check_range(const char* field, double value, double lo, double hi) {
  if (value >= lo && value <= hi) return;  // NaN fails
  std::ostringstream message;
  message << "safety." << field << " is " << value << ", but must be >= " << lo << " and <= " << hi;
  throw std::invalid_argument(message.str());
}

void check_limit(const char* field, double value) {
  if (value >= 0.0) return;  // infinity (no limit) passes, NaN fails
  std::ostringstream message;
  message << "safety.force_limits." << field << " is " << value << ", but must be >= 0 (infinity: no limit)";
  throw std::invalid_argument(message.str());
}

}  // namespace

void validate(const LoopSafetyConfig& c) {
  check_range("ramp_in_s", c.ramp_in_s, 0.0, 10.0);
  check_range("force_limits.peak_force_fraction", c.force_limits.peak_force_fraction, 0.0, 1.0);
  check_limit("insertion_force_N", c.force_limits.insertion_force_N);
  check_limit("pitch_yaw_torque_Nm", c.force_limits.pitch_yaw_torque_Nm);
  check_limit("twist_torque_Nm", c.force_limits.twist_torque_Nm);
  check_limit("grip_torque_Nm", c.force_limits.grip_torque_Nm);
  check_range("position_tolerance_fraction", c.position_tolerance_fraction, 0.0, 1.0);
  check_range("max_lateness_s", c.max_lateness_s, 0.001, 10.0);
  check_range("watchdog_timeout_s", c.watchdog_timeout_s, 0.001, 10.0);
  check_range("writer_stall_s", c.writer_stall_s, 0.001, 60.0);
  check_range("rate.tolerance_fraction", c.rate.tolerance_fraction, 0.001, 0.5);
  check_range("rate.window_s", c.rate.window_s, 0.05, 60.0);
}

namespace {

// Cut-off of the tool-tip velocity estimate. Hand motion in laparoscopy is
// below ~5 Hz; 20 Hz keeps it while an encoder count per update (8 µm/ms =
// 8 mm/s) is averaged away.
constexpr double kTipVelocityCutoff_Hz = 20.0;

bool finite(const DeviceReading& r) noexcept {
  for (const auto& joints : r.position)
    for (double v : joints)
      if (!std::isfinite(v)) return false;
  return true;
}

Vec3 to_vec3(const Eigen::Vector3d& v) noexcept { return {v.x(), v.y(), v.z()}; }

// The steps of one update that only compute (no device call, no exit of
// the loop); loop_body calls them in order.

// (reading, the VE's last force) => engine => VE => engine again: the force
// the VE computes for these positions goes to the device in this update,
// not the next.
void step_engine_and_ve(Engine& engine, VirtualEnvironment& ve, const DeviceReading& reading, double t_s,
                        double dt_s, VeInput& ve_in, VeOutput& ve_out, EventBuffer& events,
                        std::array<InstrumentOutput, 2>& engine_out) noexcept {
  events.clear();
  ve_in.t_s = t_s;
  ve_in.dt_s = dt_s;
  for (int i = 0; i < 2; ++i) {
    const auto ui = static_cast<std::size_t>(i);
    const auto& raw = reading.position[ui];
    InstrumentInput in;
    in.dt_s = dt_s;
    in.position = JointVector(raw[kJointInsertion], raw[kJointPitch], raw[kJointYaw]);
    in.ve_force_N = ve_out.tip_force_N[ui];
    engine_out[ui] = engine.update(i, in);
    auto& joints = ve_in.joints[ui];
    const JointVector& q = engine_out[ui].degraded_position;
    joints = raw;
    joints[kJointInsertion] = q[0];
    joints[kJointPitch] = q[1];
    joints[kJointYaw] = q[2];
    ve_in.tip_m[ui] = kTrocarPosition_m[ui] + engine_out[ui].degraded_tip_m;
  }
  ve.step(ve_in, ve_out, events);
  for (int i = 0; i < 2; ++i) {
    const auto ui = static_cast<std::size_t>(i);
    engine.refresh_forces(i, ve_out.tip_force_N[ui], engine_out[ui]);
  }
}

// The engine's joint forces and the VE's grip torque as the device command
// (before the force guard).
void fill_command(const std::array<InstrumentOutput, 2>& engine_out, const VeOutput& ve_out,
                  DeviceCommand& command) noexcept {
  for (std::size_t i = 0; i < 2; ++i) {
    auto& f = command.force[i];
    const JointVector& jf = engine_out[i].joint_force;
    f[kJointInsertion] = jf[0];
    f[kJointPitch] = jf[1];
    f[kJointYaw] = jf[2];
    f[kJointTwist] = 0.0;
    f[kJointGrip] = ve_out.grip_torque_Nm[i];
  }
}

// Tool-tip kinematics in the VE, for the logger and the analysis: the
// position, and its velocity low-passed at kTipVelocityCutoff_Hz.
void track_tips(const VeInput& ve_in, double dt_s, bool first, std::array<Eigen::Vector3d, 2>& tip_prev,
                std::array<Eigen::Vector3d, 2>& tip_velocity) noexcept {
  const double alpha = dt_s / (dt_s + 1.0 / (2.0 * std::numbers::pi * kTipVelocityCutoff_Hz));
  for (std::size_t i = 0; i < 2; ++i) {
    const Eigen::Vector3d& tip = ve_in.tip_m[i];
    if (!first && dt_s > 0.0) tip_velocity[i] += alpha * ((tip - tip_prev[i]) / dt_s - tip_velocity[i]);
    tip_prev[i] = tip;
  }
}

// One update as the logger stores it.
void fill_sample(LoopSample& sample, std::uint64_t tick, double t_s, double dt_s, DeviceStatus read_status,
                 const DeviceReading& reading, const std::array<InstrumentOutput, 2>& engine_out,
                 const std::array<Eigen::Vector3d, 2>& tip, const std::array<Eigen::Vector3d, 2>& tip_velocity,
                 const VeOutput& ve_out, const DeviceCommand& command) noexcept {
  sample.tick = tick;
  sample.t_s = t_s;
  sample.dt_s = dt_s;
  sample.device_status = static_cast<std::int32_t>(read_status);
  for (std::size_t i = 0; i < 2; ++i) {
    InstrumentSample& s = sample.instrument[i];
    const InstrumentOutput& o = engine_out[i];
    s.raw_position = reading.position[i];
    s.degraded_position = {o.degraded_position[0], o.degraded_position[1], o.degraded_position[2]};
    s.tip_position_m = to_vec3(tip[i]);
    s.tip_velocity_m_per_s = to_vec3(tip_velocity[i]);
    s.ve_force_N = to_vec3(ve_out.tip_force_N[i]);
    s.displayed_force_N = to_vec3(o.displayed_force_N);
    // What the motors were commanded, after the ramp and the limits.
    s.joint_force = {command.force[i][kJointInsertion], command.force[i][kJointPitch], command.force[i][kJointYaw]};
    s.engine_status = o.status;
    s.in_contact = ve_out.in_contact[i];
  }
}

}  // namespace

template <typename T>
void HapticLoop::push_or_count(SpscQueue<T>& queue, const T& item, bool wait,
                               std::atomic<std::uint64_t>& dropped) noexcept {
  while (!queue.try_push(item)) {
    if (!wait || stop_requested_.load(std::memory_order_relaxed)) {
      dropped.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    std::this_thread::yield();
  }
}

namespace {

}  // namespace

HapticLoop::HapticLoop(Device& device, Engine& engine, VirtualEnvironment& ve, Clock& clock,
                       RateSchedule schedule, const LoopConfig& config, LoopAgent* agent)
    : device_(device),
      engine_(engine),
      ve_(ve),
      clock_(clock),
      schedule_(std::move(schedule)),
      config_(config),
      agent_(agent),
      // Nothing is ever pushed when samples are not published: a full-size
      // queue would only cost its zeroing (megabytes) per loop.
      samples_(config.publish_samples ? config.sample_queue_capacity : 1),
      events_(config.publish_samples ? config.event_queue_capacity : 1) {
  validate(config.safety);
}

HapticLoop::~HapticLoop() {
  request_stop();
  join();
  if (activated_) {  // activated, never run: amplifiers off again
    device_.deactivate();
    running_.store(false, std::memory_order_release);
  }
}

bool HapticLoop::activate() {
  if (activated_) return true;
  const DeviceStatus status = device_.activate(clock_);
  device_status_.store(static_cast<std::int32_t>(status), std::memory_order_release);
  if (status != DeviceStatus::kOk) {
    stop_reason_.store(StopReason::kDeviceFault, std::memory_order_release);
    return false;
  }
  // Ratings are fixed once the device is configured; taken here, off the
  // loop thread.
  const DeviceRatings ratings = device_.ratings();
  force_guard_ = ForceGuard(ratings, config_.safety.force_limits, config_.safety.ramp_in_s);
  reading_guard_ = ReadingGuard(ratings, config_.safety.position_tolerance_fraction);
  activated_ = true;
  running_.store(true, std::memory_order_release);
  return true;
}

void HapticLoop::start_watchdog() {
  if (clock_.is_virtual()) return;
  // A device that waits for its answer (the UDP bridge's timeout_ms) names
  // its own silence (device_timeout): while the loop is in a read, and only
  // then, the watchdog waits that long on top.
  watchdog_ = std::make_unique<Watchdog>(ticks_, device_, config_.safety.watchdog_timeout_s, &device_call_,
                                         device_.read_timeout_s());
  watchdog_->start();
}

bool HapticLoop::start() {
  if (!activate()) return false;
  activated_ = false;  // the loop owns the activation from here
  start_watchdog();
  thread_ = std::thread([this] {
    realtime_result_ = apply_realtime_to_this_thread(config_.realtime);
    loop_body();
  });
  return true;
}

StopReason HapticLoop::run() {
  if (!activate()) return StopReason::kDeviceFault;
  activated_ = false;
  start_watchdog();
  const StopReason reason = loop_body();
  if (watchdog_) watchdog_->stop();
  return reason;
}

void HapticLoop::join() {
  if (thread_.joinable()) thread_.join();
  if (watchdog_) watchdog_->stop();
}

bool HapticLoop::lateness_trips(double late_s) const noexcept {
  return !clock_.is_virtual() && late_s > config_.safety.max_lateness_s;
}

StopReason HapticLoop::trip(StopReason reason, const SafetyTrip& why) noexcept {
  trip_ = why;
  finish(reason);
  return reason;
}

void HapticLoop::finish(StopReason reason) noexcept {
  // The last device calls are watched as any other (one that never returns
  // is found, named and given up on: docs/safety.md), and what they answer
  // is kept: a device that could not be set to zero force or switched off
  // is a fault of the trial's end (shutdown_status), never a normal end.
  if (watchdog_) watchdog_->watch_shutdown(kShutdownCallLimit_s);
  device_call_.store(DeviceCall::kWrite, std::memory_order_release);
  const DeviceStatus zeroed = device_.write(DeviceCommand{});
  device_call_.store(DeviceCall::kDeactivate, std::memory_order_release);
  const DeviceStatus off = device_.deactivate();
  device_call_.store(DeviceCall::kNone, std::memory_order_release);
  if (watchdog_) watchdog_->disarm();
  if (off != DeviceStatus::kOk) shutdown_call_ = DeviceCall::kDeactivate;
  else if (zeroed != DeviceStatus::kOk) shutdown_call_ = DeviceCall::kWrite;
  shutdown_status_ = off != DeviceStatus::kOk ? off : zeroed;
  if (shutdown_status_ == DeviceStatus::kOk && watchdog_ && watchdog_->shutdown_tripped()) {
    // Returned, but only after the watchdog had halted the device.
    shutdown_status_ = DeviceStatus::kTimeout;
    shutdown_call_ = watchdog_->call();
  }
  stop_reason_.store(reason, std::memory_order_release);
  running_.store(false, std::memory_order_release);
}

// One update after another until something ends the loop. Long on
// purpose: every way out (a stop, a late update, a device fault, a hung
// call, a safety trip, a stalled writer, the task done, the time limit)
// returns from this one function, in the order the safety argument needs
// (docs/safety.md), so a reader sees each exit and that zero force follows
// it (trip() and finish()). What only computes is in the named steps above.
// long-function: every exit of the loop in one place, in the safety order
StopReason HapticLoop::loop_body() {
  DeviceReading reading;
  DeviceCommand command;
  VeInput ve_in;
  VeOutput ve_out;
  EventBuffer events;
  std::array<InstrumentOutput, 2> engine_out{};
  std::array<Eigen::Vector3d, 2> tip_prev{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  std::array<Eigen::Vector3d, 2> tip_velocity{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  LoopSample sample;

  const double t0_s = clock_.now_s();
  device_.set_loop_origin(t0_s);
  double deadline_s = t0_s;           // scheduled start of the current update
  double last_start_s = t0_s;
  double complete_at_s = -1.0;
  double queue_full_since_s = -1.0;  // wall clock: when the sample queue last became full
  bool first = true;
  const auto watchdog_trip = [this] {
    return SafetyTrip{.kind = SafetyTripKind::kLoopStalled,
                      .value = watchdog_->stalled_for_s(),
                      .limit = watchdog_->timeout_s(),
                      .halt_unconfirmed = device_.halt_unconfirmed()};
  };
  const auto late_trip = [this](double late_s) {
    return SafetyTrip{.kind = SafetyTripKind::kDeadlineMissed, .value = late_s, .limit = config_.safety.max_lateness_s};
  };
  // A call the watchdog found the loop stuck in: how long it took in all.
  const auto hung_trip = [this](DeviceCall call, double call_s) {
    return SafetyTrip{.kind = SafetyTripKind::kDeviceCallHung,
                      .value = std::max(call_s, watchdog_->stalled_for_s()),
                      .limit = watchdog_->tripped_limit_s(),
                      .call = call,
                      .halt_unconfirmed = device_.halt_unconfirmed()};
  };
  const auto stall_trip = [&](DeviceCall call, double call_s) {
    return watchdog_->call() == call ? hung_trip(call, call_s) : watchdog_trip();
  };
  reading_guard_.reset();
  loop_tid_.store(static_cast<int>(::syscall(SYS_gettid)), std::memory_order_release);
  // A device that only computes never makes a stall the device's.
  const bool device_may_block = device_.calls_may_block();
  // (wall clock) => the achieved rate against the schedule's (RateMonitor).
  RateMonitor rate_monitor(config_.safety.rate);
  rate_monitor.start(t0_s);
  double asked_period_s = schedule_.nominal_period_s();  // what the schedule asked before this update
  const auto rate_trip = [&] {
    const RateViolation& v = rate_monitor.violation();
    return trip(StopReason::kRateViolation, SafetyTrip{.kind = SafetyTripKind::kRateOutOfTolerance,
                                                       .value = v.achieved_Hz,
                                                       .limit = v.asked_Hz,
                                                       .limit_low = v.tolerance_fraction,
                                                       .window_s = v.window_s});
  };
  // A trial that ends by itself: its last, partial window is judged too.
  const auto last_window_trips = [&] { return !clock_.is_virtual() && rate_monitor.finish(clock_.now_s()); };

  for (std::uint64_t tick = 0;; ++tick) {
    const double now_s = clock_.now_s();
    const double t_s = now_s - t0_s;
    // Measured, not scheduled: the engine must see the time that really
    // passed, which on a loaded machine is not the nominal period.
    const double dt_s = first ? schedule_.nominal_period_s() : now_s - last_start_s;
    if (!first) timing_.record(dt_s, now_s > deadline_s + schedule_.nominal_period_s());
    last_start_s = now_s;
    if (!first && !clock_.is_virtual() && rate_monitor.update(now_s, asked_period_s)) return rate_trip();

    if (stop_requested_.load(std::memory_order_relaxed)) {
      finish(StopReason::kStopRequested);
      return StopReason::kStopRequested;
    }
    // (wall clock) => watchdog: this update should have started at deadline_s.
    if (lateness_trips(now_s - deadline_s)) return trip(StopReason::kWatchdog, late_trip(now_s - deadline_s));

    if (device_may_block) device_call_.store(DeviceCall::kRead, std::memory_order_release);
    const DeviceStatus read_status = device_.read(reading);
    device_call_.store(DeviceCall::kNone, std::memory_order_release);
    // A read that hung: the watchdog has halted the device meanwhile.
    if (watchdog_ && watchdog_->tripped())
      return trip(StopReason::kWatchdog, stall_trip(DeviceCall::kRead, clock_.now_s() - now_s));
    if (read_status == DeviceStatus::kEndOfData) {
      finish(StopReason::kEndOfData);
      return StopReason::kEndOfData;
    }
    if (read_status != DeviceStatus::kOk || !finite(reading)) {
      const DeviceStatus reported =
          read_status != DeviceStatus::kOk ? read_status : DeviceStatus::kNonFiniteReading;
      device_status_.store(static_cast<std::int32_t>(reported), std::memory_order_release);
      finish(StopReason::kDeviceFault);
      return StopReason::kDeviceFault;
    }
    // (reading, ratings) => range and velocity checks, before anything is computed from it.
    if (const SafetyTrip why = reading_guard_.check(reading, dt_s); why.tripped())
      return trip(StopReason::kSafetyLimit, why);

    step_engine_and_ve(engine_, ve_, reading, t_s, dt_s, ve_in, ve_out, events, engine_out);

    if (agent_ != nullptr) agent_->act(LoopTickView{t_s, dt_s, reading, engine_out, ve_in, ve_out});

    fill_command(engine_out, ve_out, command);
    // A VE or agent that stalled: the watchdog has halted the device, and
    // this update's force is as stale as the stall was long.
    if (watchdog_ && watchdog_->tripped()) return trip(StopReason::kWatchdog, watchdog_trip());
    // (wall clock) => an update whose own work ran past the lateness limit
    // writes nothing it computed.
    if (!clock_.is_virtual()) {
      const double late_s = clock_.now_s() - deadline_s;
      if (lateness_trips(late_s)) return trip(StopReason::kWatchdog, late_trip(late_s));
    }
    // (command, t) => ramp-in and limits: the last stage before the motors.
    if (const int limited = force_guard_.apply(command, t_s); limited > 0)
      limited_commands_.fetch_add(static_cast<std::uint64_t>(limited), std::memory_order_relaxed);
    const double write_start_s = clock_.is_virtual() ? 0.0 : clock_.now_s();
    if (device_may_block) device_call_.store(DeviceCall::kWrite, std::memory_order_release);
    const DeviceStatus write_status = device_.write(command);
    device_call_.store(DeviceCall::kNone, std::memory_order_release);
    // A write that hung: the force it carried is long stale, and the
    // watchdog has halted the device meanwhile.
    if (watchdog_ && watchdog_->tripped() && watchdog_->call() == DeviceCall::kWrite)
      return trip(StopReason::kWatchdog, hung_trip(DeviceCall::kWrite, clock_.now_s() - write_start_s));
    if (write_status != DeviceStatus::kOk) {
      device_status_.store(static_cast<std::int32_t>(write_status), std::memory_order_release);
      finish(StopReason::kDeviceFault);
      return StopReason::kDeviceFault;
    }

    track_tips(ve_in, dt_s, first, tip_prev, tip_velocity);

    if (config_.publish_samples) {
      fill_sample(sample, tick, t_s, dt_s, read_status, reading, engine_out, tip_prev, tip_velocity, ve_out, command);
      const bool wait = config_.wait_when_full_virtual && clock_.is_virtual();
      for (int e = 0; e < events.size(); ++e) push_or_count(events_, events[e], wait, dropped_events_);
      const std::uint64_t dropped_before = dropped_samples_.load(std::memory_order_relaxed);
      push_or_count(samples_, sample, wait, dropped_samples_);
      if (events.overflow() > 0)
        dropped_events_.fetch_add(static_cast<std::uint64_t>(events.overflow()), std::memory_order_relaxed);
      // (wall clock) => writer watchdog: a queue that stays full means the
      // writer has stalled.
      if (!clock_.is_virtual()) {
        if (dropped_samples_.load(std::memory_order_relaxed) == dropped_before) {
          queue_full_since_s = -1.0;
        } else if (queue_full_since_s < 0.0) {
          queue_full_since_s = now_s;
        } else if (now_s - queue_full_since_s > config_.safety.writer_stall_s) {
          return trip(StopReason::kWatchdog, SafetyTrip{.kind = SafetyTripKind::kWriterStalled,
                                                        .value = now_s - queue_full_since_s,
                                                        .limit = config_.safety.writer_stall_s});
        }
      }
    }
    ticks_.store(tick + 1, std::memory_order_relaxed);
    elapsed_s_.store(t_s, std::memory_order_relaxed);
    first = false;

    if (complete_at_s < 0.0 && ve_.complete()) complete_at_s = t_s;
    if (complete_at_s >= 0.0 && t_s - complete_at_s >= config_.linger_after_complete_s) {
      if (last_window_trips()) return rate_trip();
      finish(StopReason::kTaskComplete);
      return StopReason::kTaskComplete;
    }
    if (t_s >= config_.max_duration_s) {
      if (last_window_trips()) return rate_trip();
      finish(StopReason::kMaxDuration);
      return StopReason::kMaxDuration;
    }

    asked_period_s = schedule_.next_period_s();
    deadline_s += asked_period_s;
    // (wall clock) => watchdog: an update that overran makes the next one late.
    const double end_s = clock_.now_s();
    if (lateness_trips(end_s - deadline_s)) return trip(StopReason::kWatchdog, late_trip(end_s - deadline_s));
    // After a stall longer than a period, restart the schedule from now
    // instead of firing a burst of catch-up updates.
    if (end_s > deadline_s + schedule_.nominal_period_s()) deadline_s = end_s;
    clock_.sleep_until(deadline_s);
  }
}

}  // namespace hapticlab
