// The haptic loop: order of operations (device -> engine -> VE -> device),
// one update of VE latency, dt from the clock, faults, stopping, queue
// overflow, timing statistics, replay, and no allocation after start.
//
// This binary replaces the global operator new to count allocations made on
// the thread that runs HapticLoop::run() (as core/engine/realtime_test.cc).
#include "core/loop/haptic_loop.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <new>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "core/common/random.h"
#include "core/device/replay_device.h"
#include "core/device/sim_device.h"
#include "core/settings/settings_json.h"
#include "core/sim/dissection_task.h"
#include "core/sim/participant.h"
#include "tests/testing/fake_device.h"

namespace {
thread_local bool counting = false;
std::atomic<long> allocations{0};
}  // namespace

// GCC cannot tell that these free() calls pair with the malloc() below.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void* operator new(std::size_t size) {
  if (counting) allocations.fetch_add(1);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
#pragma GCC diagnostic pop

namespace hapticlab {
namespace {

constexpr double kExact = 0.0;
constexpr double kForceTolerance = 1e-9;  // N or N·m: pass-through arithmetic only
constexpr double kRate_Hz = 1024.0;       // period 2^-10 s: sums of periods are exact
constexpr double kPeriod_s = 1.0 / kRate_Hz;

// --- fakes

// A device that plays scripted joint positions (one pose per read), records
// every command it receives and can be told to fail.
class ScriptedDevice final : public Device {
 public:
  ScriptedDevice() {
    writes.reserve(1 << 16);
    deactivate_after_write.reserve(4);
  }

  static DeviceJoints pose(int instrument, int n) {
    const double s = 0.001 * n + 0.3 * instrument;
    return {0.10 + 0.01 * std::sin(3.0 * s), 0.2 * std::sin(s), -0.15 * std::cos(2.0 * s),
            0.05 * instrument, 0.2 + 0.01 * instrument};
  }

  DeviceStatus configure(const DeviceConfig&) override { return DeviceStatus::kOk; }
  DeviceStatus activate(const Clock&) override {
    ++activations;
    reads = 0;
    return activate_status;
  }
  DeviceStatus read(DeviceReading& reading) noexcept override {
    const int n = reads++;
    if (n == fail_at_read) return fail_status;
    for (int i = 0; i < 2; ++i) reading.position[static_cast<std::size_t>(i)] = pose(i, n);
    if (n == nan_at_read) reading.position[1][kJointYaw] = std::numeric_limits<double>::quiet_NaN();
    return DeviceStatus::kOk;
  }
  DeviceStatus write(const DeviceCommand& command) noexcept override {
    writes.push_back(command);
    return static_cast<int>(writes.size()) - 1 == fail_at_write ? DeviceStatus::kWriteFailed
                                                               : DeviceStatus::kOk;
  }
  DeviceStatus deactivate() noexcept override {
    deactivate_after_write.push_back(writes.size());
    return DeviceStatus::kOk;
  }
  const char* name() const noexcept override { return "scripted"; }

  DeviceStatus activate_status = DeviceStatus::kOk;
  int fail_at_read = -1;
  DeviceStatus fail_status = DeviceStatus::kReadFailed;
  int nan_at_read = -1;
  int fail_at_write = -1;
  int reads = 0;
  int activations = 0;
  std::vector<DeviceCommand> writes;
  std::vector<std::size_t> deactivate_after_write;  // writes.size() at each deactivate()
};

// A VE whose tip force is a known function of its step count, which records
// what it was given, and which can report completion from a time on.
class RecordingVe final : public VirtualEnvironment {
 public:
  RecordingVe() {
    inputs.reserve(1 << 16);
    outputs.reserve(1 << 16);
  }

  static Eigen::Vector3d force(int instrument, int n) {
    return {0.1 * std::sin(0.05 * n + instrument), 0.05 + 0.01 * instrument, -0.2 - 0.001 * (n % 300)};
  }

  void step(const VeInput& in, VeOutput& out, EventBuffer&) noexcept override {
    const int n = static_cast<int>(inputs.size());
    inputs.push_back(in);
    for (int i = 0; i < 2; ++i) {
      const auto ui = static_cast<std::size_t>(i);
      out.tip_force_N[ui] = zero_force ? Eigen::Vector3d::Zero() : force(i, n);
      out.grip_torque_Nm[ui] = zero_force ? 0.0 : 0.001 * (n % 7) + 0.01 * i;
      out.in_contact[ui] = !zero_force;
    }
    outputs.push_back(out);
    if (in.t_s >= complete_from_s) complete_ = true;
  }
  bool complete() const noexcept override { return complete_; }

  bool zero_force = false;
  double complete_from_s = std::numeric_limits<double>::infinity();
  std::vector<VeInput> inputs;
  std::vector<VeOutput> outputs;

 private:
  bool complete_ = false;
};

// A virtual clock that wakes late by a scripted amount, like a loaded
// machine: the loop must measure dt, not assume the schedule.
class LateClock final : public Clock {
 public:
  double now_s() const noexcept override { return now_s_; }
  void sleep_until(double t_s) noexcept override {
    static constexpr double kLateness_s[] = {0.0, 0.4e-3, 0.1e-3, 0.0, 0.7e-3};
    const double late = kLateness_s[wakeups_++ % 5];
    if (t_s + late > now_s_) now_s_ = t_s + late;
  }
  bool is_virtual() const noexcept override { return true; }

 private:
  double now_s_ = 0.0;
  int wakeups_ = 0;
};

std::vector<LoopSample> drain(HapticLoop& loop) {
  std::vector<LoopSample> out;
  LoopSample s;
  while (loop.samples().try_pop(s)) out.push_back(s);
  return out;
}

using testing::all_zero;

LoopConfig short_run(double max_duration_s) {
  LoopConfig config;
  config.max_duration_s = max_duration_s;
  return config;
}

EngineSettings load_example(const std::string& name) {
  const char* dir = std::getenv("HAPTICLAB_SOURCE_DIR");
  const std::string root = dir != nullptr ? dir : HAPTICLAB_SOURCE_DIR;
  return load_settings_file(root + "/examples/settings/" + name + ".json").engine;
}

// --- order of operations

TEST(HapticLoopTest, VeGetsDegradedPositionsAndDeviceGetsTheVeForceOfTheSameUpdate) {
  ScriptedDevice device;
  Engine engine(EngineSettings{}, {JointVector(0.10, 0.0, -0.15), JointVector(0.10, 0.0, -0.15)});
  RecordingVe ve;
  VirtualClock clock;
  // No ramp-in: this test follows the engine's force to the device
  // unscaled (force_guard_test and safety_test check the ramp).
  LoopConfig config = short_run(0.2);
  config.safety.ramp_in_s = 0.0;
  HapticLoop loop(device, engine, ve, clock, RateSchedule::fixed(kRate_Hz), config);
  ASSERT_EQ(loop.run(), StopReason::kMaxDuration);
  const std::vector<LoopSample> samples = drain(loop);
  ASSERT_EQ(samples.size(), loop.ticks());
  ASSERT_EQ(ve.inputs.size(), samples.size());
  ASSERT_GE(device.writes.size(), samples.size());

  for (std::size_t n = 0; n < samples.size(); ++n) {
    SCOPED_TRACE("update " + std::to_string(n));
    const LoopSample& s = samples[n];
    EXPECT_EQ(s.tick, n);
    for (int i = 0; i < 2; ++i) {
      const auto ui = static_cast<std::size_t>(i);
      const InstrumentSample& in = s.instrument[ui];
      const DeviceJoints raw = ScriptedDevice::pose(i, static_cast<int>(n));
      EXPECT_EQ(in.raw_position, raw);
      // Device -> engine -> VE: the VE sees exactly the engine's degraded
      // joints; twist and grip come straight from the device.
      const DeviceJoints& seen = ve.inputs[n].joints[ui];
      EXPECT_EQ(seen[kJointInsertion], in.degraded_position[0]);
      EXPECT_EQ(seen[kJointPitch], in.degraded_position[1]);
      EXPECT_EQ(seen[kJointYaw], in.degraded_position[2]);
      EXPECT_EQ(seen[kJointTwist], raw[kJointTwist]);
      EXPECT_EQ(seen[kJointGrip], raw[kJointGrip]);
      // High fidelity: the degraded joints are the device's.
      for (int a = 0; a < 3; ++a) EXPECT_NEAR(in.degraded_position[a], raw[a], 1e-12);

      // The VE's force of update n is logged with update n, and the engine
      // (device -> engine -> VE -> engine -> device) displays it in update
      // n too: High Fidelity passes it through (to rounding: the displayed
      // force is the joint commands mapped back to the tip).
      const Eigen::Vector3d f_now = ve.outputs[n].tip_force_N[ui];
      EXPECT_EQ(in.ve_force_N, (Vec3{f_now.x(), f_now.y(), f_now.z()}));
      const JointVector q(raw[kJointInsertion], raw[kJointPitch], raw[kJointYaw]);
      const JointVector expected = world_to_joint(q, f_now);
      for (int a = 0; a < 3; ++a) EXPECT_NEAR(in.joint_force[a], expected[a], kForceTolerance) << a;
      for (int a = 0; a < 3; ++a) EXPECT_NEAR(in.displayed_force_N[a], f_now[a], kForceTolerance) << a;

      // Engine -> device: the command is the engine's joint force, the grip
      // gets the VE's grip torque, the unactuated twist nothing.
      const DeviceJoints& cmd = device.writes[n].force[ui];
      EXPECT_EQ(cmd[kJointInsertion], in.joint_force[0]);
      EXPECT_EQ(cmd[kJointPitch], in.joint_force[1]);
      EXPECT_EQ(cmd[kJointYaw], in.joint_force[2]);
      EXPECT_EQ(cmd[kJointTwist], 0.0);
      EXPECT_EQ(cmd[kJointGrip], ve.outputs[n].grip_torque_Nm[ui]);
      EXPECT_TRUE(in.in_contact);
    }
  }
  // The force is not trivially zero: the check above could fail.
  EXPECT_GT(std::abs(samples.back().instrument[1].joint_force[0]), 0.05);
}

// --- dt from the clock

TEST(HapticLoopTest, DtIsThePeriodWithAFixedVirtualScheduleAndFirstUpdateUsesTheNominalPeriod) {
  ScriptedDevice device;
  Engine engine(EngineSettings{});
  RecordingVe ve;
  VirtualClock clock;
  HapticLoop loop(device, engine, ve, clock, RateSchedule::fixed(kRate_Hz), short_run(0.5));
  ASSERT_EQ(loop.run(), StopReason::kMaxDuration);
  const std::vector<LoopSample> samples = drain(loop);
  ASSERT_EQ(samples.size(), 513u);  // t = 0, 1/1024, ..., 0.5 s
  for (std::size_t n = 0; n < samples.size(); ++n) {
    EXPECT_EQ(samples[n].dt_s, kPeriod_s) << n;
    EXPECT_EQ(samples[n].t_s, static_cast<double>(n) * kPeriod_s) << n;
    EXPECT_EQ(ve.inputs[n].dt_s, kPeriod_s) << n;
    EXPECT_EQ(ve.inputs[n].t_s, samples[n].t_s) << n;
  }
}

TEST(HapticLoopTest, DtIsMeasuredFromTheClockNotTakenFromTheSchedule) {
  ScriptedDevice device;
  Engine engine(EngineSettings{});
  RecordingVe ve;
  LateClock clock;
  HapticLoop loop(device, engine, ve, clock, RateSchedule::fixed(1000.0), short_run(0.1));
  ASSERT_EQ(loop.run(), StopReason::kMaxDuration);
  const std::vector<LoopSample> samples = drain(loop);
  ASSERT_GT(samples.size(), 50u);
  EXPECT_DOUBLE_EQ(samples[0].dt_s, 1e-3);  // nothing measured yet: the nominal period
  int off_schedule = 0;
  for (std::size_t n = 1; n < samples.size(); ++n) {
    const double measured = samples[n].t_s - samples[n - 1].t_s;
    EXPECT_DOUBLE_EQ(samples[n].dt_s, measured) << n;
    EXPECT_EQ(ve.inputs[n].dt_s, samples[n].dt_s) << n;
    if (std::abs(measured - 1e-3) > 1e-5) ++off_schedule;
  }
  EXPECT_GT(off_schedule, 20);  // the clock really was late
}

// --- faults

TEST(HapticLoopTest, FailedReadStopsWithZeroForcesAndDeactivates) {
  ScriptedDevice device;
  device.fail_at_read = 40;
  Engine engine(EngineSettings{});
  RecordingVe ve;
  VirtualClock clock;
  HapticLoop loop(device, engine, ve, clock, RateSchedule::fixed(kRate_Hz), short_run(2.0));
  EXPECT_EQ(loop.run(), StopReason::kDeviceFault);
  EXPECT_EQ(loop.stop_reason(), StopReason::kDeviceFault);
  EXPECT_EQ(loop.device_status(), DeviceStatus::kReadFailed);
  EXPECT_FALSE(loop.running());
  EXPECT_EQ(loop.ticks(), 40u);
  EXPECT_EQ(drain(loop).size(), 40u);
  // Forces were being displayed; the last write zeroes them, then deactivate.
  ASSERT_EQ(device.writes.size(), 41u);
  EXPECT_FALSE(all_zero(device.writes[39]));
  EXPECT_TRUE(all_zero(device.writes.back()));
  ASSERT_EQ(device.deactivate_after_write.size(), 1u);
  EXPECT_EQ(device.deactivate_after_write[0], device.writes.size());
}

TEST(HapticLoopTest, NonFiniteReadingWithOkStatusIsStillAFault) {
  ScriptedDevice device;
  device.nan_at_read = 25;
  Engine engine(EngineSettings{});
  RecordingVe ve;
  VirtualClock clock;
  HapticLoop loop(device, engine, ve, clock, RateSchedule::fixed(kRate_Hz), short_run(2.0));
  EXPECT_EQ(loop.run(), StopReason::kDeviceFault);
  EXPECT_EQ(loop.device_status(), DeviceStatus::kNonFiniteReading);
  EXPECT_EQ(loop.ticks(), 25u);
  EXPECT_EQ(ve.inputs.size(), 25u);  // the NaN never reached the VE
  ASSERT_FALSE(device.writes.empty());
  EXPECT_TRUE(all_zero(device.writes.back()));
  EXPECT_EQ(device.deactivate_after_write.size(), 1u);
  for (const LoopSample& s : drain(loop))
    for (const auto& in : s.instrument)
      for (double f : in.joint_force) EXPECT_TRUE(std::isfinite(f));
}

TEST(HapticLoopTest, FailedWriteStopsWithZeroForces) {
  ScriptedDevice device;
  device.fail_at_write = 10;
  Engine engine(EngineSettings{});
  RecordingVe ve;
  VirtualClock clock;
  HapticLoop loop(device, engine, ve, clock, RateSchedule::fixed(kRate_Hz), short_run(2.0));
  EXPECT_EQ(loop.run(), StopReason::kDeviceFault);
  EXPECT_EQ(loop.device_status(), DeviceStatus::kWriteFailed);
  ASSERT_EQ(device.writes.size(), 12u);
  EXPECT_TRUE(all_zero(device.writes.back()));
  EXPECT_EQ(device.deactivate_after_write.size(), 1u);
}

TEST(HapticLoopTest, RefusedActivationDoesNotStart) {
  ScriptedDevice device;
  device.activate_status = DeviceStatus::kNotConfigured;
  Engine engine(EngineSettings{});
  RecordingVe ve;
  VirtualClock clock;
  HapticLoop loop(device, engine, ve, clock, RateSchedule::fixed(kRate_Hz), short_run(2.0));
  EXPECT_FALSE(loop.start());
  EXPECT_FALSE(loop.running());
  EXPECT_EQ(loop.stop_reason(), StopReason::kDeviceFault);
  EXPECT_EQ(loop.device_status(), DeviceStatus::kNotConfigured);
  EXPECT_EQ(device.reads, 0);
  EXPECT_TRUE(device.writes.empty());
}

// The simulated workstation's injected faults, through the loop.
class SimDeviceFaultTest : public ::testing::TestWithParam<DeviceStatus> {};

TEST_P(SimDeviceFaultTest, EndsTheLoopWithTheDevicesStatus) {
  SimDevice device;
  for (int i = 0; i < 2; ++i) device.set_position(i, Participant::start_pose(i));
  ASSERT_EQ(device.configure({}), DeviceStatus::kOk);
  device.inject_fault(GetParam(), 0.05);
  Engine engine(EngineSettings{});
  RecordingVe ve;
  VirtualClock clock;
  HapticLoop loop(device, engine, ve, clock, RateSchedule::fixed(kRate_Hz), short_run(1.0));
  EXPECT_EQ(loop.run(), StopReason::kDeviceFault);
  EXPECT_EQ(loop.device_status(), GetParam());
  EXPECT_NEAR(loop.elapsed_s(), 0.05, 2 * kPeriod_s);
  for (int i = 0; i < 2; ++i)
    for (double f : device.motor_force(i)) EXPECT_TRUE(std::isfinite(f));
  DeviceReading reading;
  EXPECT_EQ(device.read(reading), DeviceStatus::kNotActive);  // deactivated
}

INSTANTIATE_TEST_SUITE_P(Faults, SimDeviceFaultTest,
                         ::testing::Values(DeviceStatus::kReadFailed, DeviceStatus::kNonFiniteReading,
                                           DeviceStatus::kOutOfRange, DeviceStatus::kWriteFailed),
                         [](const auto& info) { return std::string(to_string(info.param)); });

// --- stopping

TEST(HapticLoopTest, RequestStopFromAnotherThreadStopsAWallClockLoopPromptly) {
  ScriptedDevice device;
  Engine engine(EngineSettings{});
  RecordingVe ve;
  WallClock clock;
  LoopConfig config = short_run(600.0);
  // A loaded test machine must not trip the 20 ms watchdogs here: this test
  // is about the stop (safety_test covers the watchdogs).
  config.safety.max_lateness_s = config.safety.watchdog_timeout_s = 1.0;
  HapticLoop loop(device, engine, ve, clock, RateSchedule::fixed(1000.0), config);
  ASSERT_TRUE(loop.start());
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_TRUE(loop.running());
  const auto asked = std::chrono::steady_clock::now();
  loop.request_stop();
  while (loop.running() && std::chrono::steady_clock::now() - asked < std::chrono::seconds(2))
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  const double took_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - asked).count();
  loop.join();
  EXPECT_FALSE(loop.running());
  EXPECT_EQ(loop.stop_reason(), StopReason::kStopRequested);
  EXPECT_LT(took_s, 0.1);  // a period or two, with generous room for a loaded CI machine
  EXPECT_GT(loop.ticks(), 5u);
  ASSERT_FALSE(device.writes.empty());
  EXPECT_TRUE(all_zero(device.writes.back()));
  EXPECT_EQ(device.deactivate_after_write.size(), 1u);
}

TEST(HapticLoopTest, StopsAtMaxDuration) {
  ScriptedDevice device;
  Engine engine(EngineSettings{});
  RecordingVe ve;
  VirtualClock clock;
  HapticLoop loop(device, engine, ve, clock, RateSchedule::fixed(kRate_Hz), short_run(0.25));
  EXPECT_EQ(loop.run(), StopReason::kMaxDuration);
  EXPECT_EQ(loop.ticks(), 257u);  // 0 .. 0.25 s inclusive
  EXPECT_EQ(loop.elapsed_s(), 0.25);
  EXPECT_TRUE(all_zero(device.writes.back()));
  EXPECT_EQ(device.deactivate_after_write.size(), 1u);
}

TEST(HapticLoopTest, StopsOnTaskCompleteAfterTheLingerTime) {
  ScriptedDevice device;
  Engine engine(EngineSettings{});
  RecordingVe ve;
  ve.complete_from_s = 0.1;
  VirtualClock clock;
  LoopConfig config = short_run(10.0);
  config.linger_after_complete_s = 0.2;
  HapticLoop loop(device, engine, ve, clock, RateSchedule::fixed(kRate_Hz), config);
  EXPECT_EQ(loop.run(), StopReason::kTaskComplete);
  // Complete at the first update with t >= 0.1 s; stop 0.2 s later.
  const double complete_at_s = std::ceil(0.1 * kRate_Hz) * kPeriod_s;
  EXPECT_GE(loop.elapsed_s(), complete_at_s + 0.2);
  EXPECT_LT(loop.elapsed_s(), complete_at_s + 0.2 + kPeriod_s);
  EXPECT_TRUE(all_zero(device.writes.back()));
}

// --- queues

TEST(HapticLoopTest, FullQueueWithTheWallClockDropsAndCountsSamples) {
  ScriptedDevice device;
  Engine engine(EngineSettings{});
  RecordingVe ve;
  WallClock clock;
  LoopConfig config = short_run(0.1);
  config.sample_queue_capacity = 8;
  // Full for most of the 0.1 s run, below the 0.25 s writer watchdog; and
  // a loaded test machine must not trip the 20 ms ones.
  config.safety.max_lateness_s = config.safety.watchdog_timeout_s = 1.0;
  HapticLoop loop(device, engine, ve, clock, RateSchedule::fixed(1000.0), config);
  EXPECT_EQ(loop.run(), StopReason::kMaxDuration);  // nobody consumes
  ASSERT_GT(loop.ticks(), 50u);
  EXPECT_EQ(loop.dropped_samples(), loop.ticks() - 8);
  const std::vector<LoopSample> kept = drain(loop);
  ASSERT_EQ(kept.size(), 8u);
  for (std::size_t n = 0; n < kept.size(); ++n) EXPECT_EQ(kept[n].tick, n);  // the oldest were kept
}

TEST(HapticLoopTest, FullQueueWithTheVirtualClockWaitsForASlowConsumer) {
  ScriptedDevice device;
  Engine engine(EngineSettings{});
  RecordingVe ve;
  VirtualClock clock;
  LoopConfig config = short_run(0.3);
  config.sample_queue_capacity = 8;
  HapticLoop loop(device, engine, ve, clock, RateSchedule::fixed(kRate_Hz), config);
  std::vector<std::uint64_t> ticks;
  ticks.reserve(1024);
  ASSERT_TRUE(loop.start());
  LoopSample s;
  for (;;) {
    const bool running = loop.running();  // read before popping: nothing is left behind
    while (loop.samples().try_pop(s)) {
      ticks.push_back(s.tick);
      std::this_thread::sleep_for(std::chrono::microseconds(20));  // a slow logger
    }
    if (!running) break;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  loop.join();
  EXPECT_EQ(loop.stop_reason(), StopReason::kMaxDuration);
  EXPECT_EQ(loop.dropped_samples(), 0u);
  ASSERT_EQ(ticks.size(), loop.ticks());
  for (std::size_t n = 0; n < ticks.size(); ++n) ASSERT_EQ(ticks[n], n);
}

// --- timing

TEST(HapticLoopTest, TimingStatsCountEveryPeriodAndHaveTheFixedMedian) {
  ScriptedDevice device;
  Engine engine(EngineSettings{});
  RecordingVe ve;
  VirtualClock clock;
  LoopConfig config = short_run(0.5);
  config.publish_samples = false;
  HapticLoop loop(device, engine, ve, clock, RateSchedule::fixed(1000.0), config);
  EXPECT_EQ(loop.run(), StopReason::kMaxDuration);
  const LoopTimingSummary t = loop.timing();
  EXPECT_EQ(t.count, loop.ticks() - 1);
  // The histogram reports the centre of the 1 µs bin: within half a bin.
  EXPECT_NEAR(t.p50_period_s, 1e-3, 0.5e-6 + 1e-12);
  EXPECT_NEAR(t.p99_period_s, 1e-3, 0.5e-6 + 1e-12);
  EXPECT_NEAR(t.mean_period_s, 1e-3, 1e-12);
  EXPECT_NEAR(t.max_period_s, 1e-3, 1e-12);
  EXPECT_EQ(t.overruns, 0u);
  EXPECT_EQ(t.rejected, 0u);
  EXPECT_EQ(drain(loop).size(), 0u);  // publish_samples = false
}

// --- replay

// A 1 kHz recording, time stamps base + k/1000 s, replayed by a 1 kHz loop
// on the virtual clock: update k must see frame k exactly. Base 0 is a
// recording that starts at zero; base 100 s one stamped with the device's
// own clock (seconds since power-up).
class ReplayThroughLoopTest : public ::testing::TestWithParam<double> {};

TEST_P(ReplayThroughLoopTest, EveryUpdateSeesItsRecordedFrameBitForBit) {
  const double base_s = GetParam();
  Random rng(7);
  std::vector<ReplayFrame> frames(1600);
  for (std::size_t k = 0; k < frames.size(); ++k) {
    frames[k].t_s = base_s + static_cast<double>(k) / 1000.0;
    for (auto& q : frames[k].position)
      q = {rng.uniform(0.05, 0.15), rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3),
           rng.uniform(-0.5, 0.5), rng.uniform(0.0, 0.3)};
  }
  ReplayDevice device(frames);
  ASSERT_EQ(device.configure({}), DeviceStatus::kOk);
  Engine engine(EngineSettings{});
  RecordingVe ve;
  ve.zero_force = true;
  VirtualClock clock;
  HapticLoop loop(device, engine, ve, clock, RateSchedule::fixed(1000.0), short_run(1.5));
  EXPECT_EQ(loop.run(), StopReason::kMaxDuration);
  const std::vector<LoopSample> samples = drain(loop);
  ASSERT_GE(samples.size(), 1500u);
  ASSERT_LE(samples.size(), 1502u);
  int mismatches = 0;
  for (const LoopSample& s : samples) {
    EXPECT_EQ(s.device_status, static_cast<std::int32_t>(DeviceStatus::kOk));
    const ReplayFrame& f = frames[s.tick];
    for (std::size_t i = 0; i < 2; ++i) {
      if (std::memcmp(s.instrument[i].raw_position.data(), f.position[i].data(),
                      sizeof(DeviceJoints)) != 0) {
        if (++mismatches <= 3) ADD_FAILURE() << "update " << s.tick << " (t_s " << s.t_s
                                             << "), instrument " << i << ": not frame " << s.tick;
      }
    }
  }
  EXPECT_EQ(mismatches, 0) << "of " << 2 * samples.size() << " instrument readings";
}

// The end of a recording is the normal end of a replay: zero forces, the
// loop stops with kEndOfData after the last frame, and the device status
// stays ok (a fault would make a session re-queue the trial).
TEST(HapticLoopTest, ReplayEndsWithEndOfDataNotAFault) {
  std::vector<ReplayFrame> frames(300);
  for (std::size_t k = 0; k < frames.size(); ++k) {
    frames[k].t_s = static_cast<double>(k) / 1000.0;
    for (auto& q : frames[k].position) q = {0.1, 0.0, 0.0, 0.0, 0.0};
  }
  ReplayDevice device(frames);
  ASSERT_EQ(device.configure({}), DeviceStatus::kOk);
  Engine engine(EngineSettings{});
  RecordingVe ve;  // a nonzero force: the command is nonzero until the end
  VirtualClock clock;
  HapticLoop loop(device, engine, ve, clock, RateSchedule::fixed(1000.0), short_run(1.5));
  EXPECT_EQ(loop.run(), StopReason::kEndOfData);
  EXPECT_EQ(loop.device_status(), DeviceStatus::kOk);
  EXPECT_STREQ(to_string(StopReason::kEndOfData), "end_of_data");
  const std::vector<LoopSample> samples = drain(loop);
  EXPECT_GE(samples.size(), 299u);
  EXPECT_LE(samples.size(), 301u);
  for (const auto& f : device.last_command().force)
    for (double v : f) EXPECT_EQ(v, 0.0);
}

INSTANTIATE_TEST_SUITE_P(RecordingStart, ReplayThroughLoopTest, ::testing::Values(0.0, 100.0),
                         [](const auto& info) { return info.param == 0.0 ? "AtZero" : "At100s"; });

// --- real-time rule: no allocation once the loop runs

TEST(HapticLoopTest, FullRigNeverAllocatesInsideRun) {
  SimDeviceParams params;
  params.max_substep_s = 1e-3;
  SimDevice device(params);
  std::array<JointVector, 2> start{};
  for (int i = 0; i < 2; ++i) {
    const DeviceJoints pose = Participant::start_pose(i);
    device.set_position(i, pose);
    start[static_cast<std::size_t>(i)] = JointVector(pose[kJointInsertion], pose[kJointPitch], pose[kJointYaw]);
  }
  ASSERT_EQ(device.configure({}), DeviceStatus::kOk);
  Engine engine(load_example("all_degradations"), start);
  DissectionTask task(3);
  Participant participant(ParticipantTraits::sample(5), ParticipantTrial{3, 2, 0.0, {}}, device, task);
  VirtualClock clock;
  LoopConfig config = short_run(6.0);  // fits the queues: no consumer needed
  HapticLoop loop(device, engine, task, clock, RateSchedule::fixed(1000.0), config, &participant);

  allocations = 0;
  counting = true;
  const StopReason reason = loop.run();
  counting = false;
  EXPECT_EQ(reason, StopReason::kMaxDuration);
  EXPECT_EQ(allocations.load(), 0);
  EXPECT_EQ(loop.dropped_samples(), 0u);
  // The rig really did something: tools in contact, tissue burnt.
  const std::vector<LoopSample> samples = drain(loop);
  ASSERT_EQ(samples.size(), loop.ticks());
  int contact = 0;
  for (const LoopSample& s : samples) contact += s.instrument[1].in_contact ? 1 : 0;
  EXPECT_GT(contact, 100);
  TaskEvent e;
  int events = 0;
  while (loop.events().try_pop(e)) ++events;
  EXPECT_GT(events, 2);
}

}  // namespace
}  // namespace hapticlab
