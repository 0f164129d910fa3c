// PluginDevice against real shared libraries: the shipped sim plugin
// (hapticlab_sim_device.so) and the fake plugins of fake_device_plugin.c.
#include "core/device/plugin_device.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <future>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/device/device_factory.h"
#include "core/device/sim_device.h"
#include "core/common/clock.h"
#include "tests/testing/test_paths.h"
#include "tests/testing/thrown.h"
#include "tests/testing/files.h"

namespace hapticlab {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

const std::string kFakeAbi2 = HAPTICLAB_FAKE_PLUGIN_ABI2_PATH;
const std::string kFakeNoEntry = HAPTICLAB_FAKE_PLUGIN_NO_ENTRY_PATH;

using testing::thrown;

using testing::slurp;

fs::path temp_path(const std::string& name) {
  return fs::temp_directory_path() / ("hapticlab_plugin_device_" + name + "_" + std::to_string(::getpid()));
}

TEST(PluginDeviceTest, SimPluginMovesExactlyAsTheBuiltInSimDevice) {
  SimDevice direct(sim_backend_params());
  PluginDevice plugin(kSimPlugin, {});
  ASSERT_NE(plugin.hand_attachment(), nullptr);
  VirtualClock clock_direct, clock_plugin;
  const DeviceConfig config{1000.0, 42};
  ASSERT_EQ(direct.configure(config), DeviceStatus::kOk);
  ASSERT_EQ(plugin.configure(config), DeviceStatus::kOk);
  const DeviceJoints pose = {0.05, 0.1, -0.1, 0.0, 0.2};
  for (int i = 0; i < 2; ++i) {
    ASSERT_TRUE(direct.set_start_pose(i, pose));
    ASSERT_TRUE(plugin.hand_attachment()->set_start_pose(i, pose));
  }
  ASSERT_EQ(direct.activate(clock_direct), DeviceStatus::kOk);
  ASSERT_EQ(plugin.activate(clock_plugin), DeviceStatus::kOk);

  // A hand pulling the left instrument in and a motor pushing back, the
  // reference changing every 100 updates: every part of the physics runs.
  DeviceCommand command;
  command.force[0] = {-0.5, 0.01, -0.02, 0.0, 0.005};
  command.force[1] = {0.3, -0.01, 0.0, 0.0, 0.0};
  for (int k = 1; k <= 500; ++k) {
    if (k % 100 == 1) {
      HandCouplings hand{};
      for (int j = 0; j < kNumDeviceJoints; ++j)
        hand[static_cast<std::size_t>(j)] = {pose[static_cast<std::size_t>(j)] + 0.01 * (k / 100 + 1), 0.02, 200.0,
                                             2.0, 0.1, 0.05};
      direct.set_hand(0, hand);
      plugin.set_hand(0, hand);
    }
    clock_direct.sleep_until(k * 1e-3);
    clock_plugin.sleep_until(k * 1e-3);
    DeviceReading a, b;
    ASSERT_EQ(direct.read(a), DeviceStatus::kOk);
    ASSERT_EQ(plugin.read(b), DeviceStatus::kOk);
    ASSERT_EQ(a.position, b.position) << "update " << k;
    ASSERT_EQ(a.device_time_s, b.device_time_s);
    ASSERT_EQ(direct.write(command), DeviceStatus::kOk);
    ASSERT_EQ(plugin.write(command), DeviceStatus::kOk);
  }
  EXPECT_EQ(direct.hand_force(0), plugin.hand_force(0));
  EXPECT_EQ(direct.motor_force(1), plugin.motor_force(1));
  // Not a device at rest: the hand moved the left insertion by centimetres.
  EXPECT_GT(std::abs(direct.true_position(0)[kJointInsertion] - pose[kJointInsertion]), 0.01);
  EXPECT_EQ(plugin.deactivate(), DeviceStatus::kOk);
  EXPECT_EQ(plugin.ratings().joint[1][kJointGrip].peak_force, workstation_ratings().joint[1][kJointGrip].peak_force);
  EXPECT_STREQ(plugin.name(), "sim-plugin");
}

TEST(PluginDeviceTest, MissingFileIsRefusedWithItsPath) {
  EXPECT_EQ(thrown<std::runtime_error>([] { PluginDevice("/nonexistent/acme.so", {}); }),
            "plugin /nonexistent/acme.so: no such file");
}

TEST(PluginDeviceTest, AFileThatIsNoLibraryIsRefused) {
  const fs::path path = temp_path("text.so");
  std::ofstream(path) << "not a library\n";
  const std::string message = thrown<std::runtime_error>([&] { PluginDevice(path.string(), {}); });
  fs::remove(path);
  EXPECT_THAT(message, HasSubstr("plugin " + path.string() + " could not be loaded: "));
}

TEST(PluginDeviceTest, ALibraryWithoutTheEntryPointIsRefused) {
  EXPECT_EQ(thrown<std::runtime_error>([] { PluginDevice(kFakeNoEntry, {}); }),
            "plugin " + kFakeNoEntry +
                " does not export hl_device_plugin_entry(), so it is not a HapticLab device plugin (see "
                "hapticlab/device_plugin.h)");
}

TEST(PluginDeviceTest, AnotherAbiVersionIsRefusedWithBothVersions) {
  EXPECT_EQ(thrown<std::runtime_error>([] { PluginDevice(kFakeAbi2, {}); }),
            "plugin " + kFakeAbi2 +
                " was built for device ABI 2, this HapticLab supports 1; rebuild it against "
                "hapticlab/device_plugin.h of this version");
}

TEST(PluginDeviceTest, ThePluginRejectsAnUnknownOptionThroughItsErrorBuffer) {
  EXPECT_EQ(thrown<std::invalid_argument>([] { PluginDevice(kSimPlugin, {{"stiffness", "3"}}); }),
            "plugin " + kSimPlugin +
                " refused its options: 'stiffness' is not an option of the simulated workstation; it takes "
                "max_substep_s");
  // An option the sim plugin knows, with a value SimDevice refuses.
  EXPECT_THAT(thrown<std::invalid_argument>([] { PluginDevice(kSimPlugin, {{"max_substep_s", "0.5"}}); }),
              HasSubstr("max_substep_s"));
  PluginDevice ok(kSimPlugin, {{"max_substep_s", "0.25e-3"}});
}

TEST(PluginDeviceTest, InvalidRatingsFailConfigureNamingJointFieldAndValue) {
  PluginDevice device(kFake, {{"fault", "invalid_ratings"}});
  EXPECT_EQ(device.configure({}), DeviceStatus::kInvalidConfig);
  EXPECT_EQ(device.configure_error(), "plugin " + kFake +
                                          " reports invalid ratings: right grip peak_force 0.05 must be >= "
                                          "continuous_force 0.1");
}

TEST(PluginDeviceTest, CheckRatingsNamesEachRule) {
  const auto broken = [](auto change) {
    DeviceRatings r = workstation_ratings();
    change(r.joint[0][kJointPitch]);
    return check_ratings("plugin x.so", r);
  };
  EXPECT_EQ(check_ratings("plugin x.so", workstation_ratings()), "");
  EXPECT_EQ(broken([](DeviceJointRating& j) { j.max_velocity = std::numeric_limits<double>::quiet_NaN(); }),
            "plugin x.so reports invalid ratings: left pitch max_velocity is nan; it must be a finite number");
  EXPECT_EQ(broken([](DeviceJointRating& j) { j.max_position = j.min_position; }),
            "plugin x.so reports invalid ratings: left pitch max_position -0.872665 must be > min_position "
            "-0.872665");
  EXPECT_EQ(broken([](DeviceJointRating& j) { j.continuous_force = -1.0; }),
            "plugin x.so reports invalid ratings: left pitch continuous_force -1 must be >= 0");
  EXPECT_EQ(broken([](DeviceJointRating& j) { j.max_velocity = 0.0; }),
            "plugin x.so reports invalid ratings: left pitch max_velocity 0 must be > 0");
  // Finite but beyond any hand-held device: each would switch a guard off
  // (a plugin reporting 1.8e308 everywhere drove force from a 5 m reading).
  EXPECT_EQ(broken([](DeviceJointRating& j) { j.max_position = std::numeric_limits<double>::max(); }),
            "plugin x.so reports invalid ratings: left pitch max_position 1.79769e+308 is beyond +-12.5664 rad, "
            "more than any hand-held device travels (it would switch the range guard off)");
  EXPECT_EQ(broken([](DeviceJointRating& j) { j.max_velocity = 101.0; }),
            "plugin x.so reports invalid ratings: left pitch max_velocity 101 is above 100 rad/s, faster than any "
            "hand moves an instrument (it would switch the speed guard off)");
  EXPECT_EQ(broken([](DeviceJointRating& j) { j.peak_force = 21.0; }),
            "plugin x.so reports invalid ratings: left pitch peak_force 21 is above 20 N·m, more than any hand-held "
            "device exerts (it would switch the force clip off)");
  DeviceRatings far = workstation_ratings();
  far.joint[1][kJointInsertion].min_position = -1.5;
  EXPECT_EQ(check_ratings("plugin x.so", far),
            "plugin x.so reports invalid ratings: right insertion min_position -1.5 is beyond +-1 m, more than any "
            "hand-held device travels (it would switch the range guard off)");
}

// A name with a newline or an escape sequence would forge lines on the
// operator's terminal: read once, bounded, and shown with '?' for them.
TEST(PluginDeviceTest, ThePluginsNameIsShownPrintableAndBounded) {
  PluginDevice plain(kFake, {});
  EXPECT_STREQ(plain.name(), "fake");
  PluginDevice forged(kFake, {{"name", "fake\nOK: calibrated\x1b[0m"}});
  EXPECT_STREQ(forged.name(), "fake?OK: calibrated?[0m");
  PluginDevice longer(kFake, {{"name", std::string(100, 'x')}});
  EXPECT_EQ(std::string(longer.name()), std::string(63, 'x'));
}

// Configures and activates `device`, then reads `reads` times, each OK.
void start_and_read(PluginDevice& device, const Clock& clock, int reads, DeviceReading& reading) {
  ASSERT_EQ(device.configure({}), DeviceStatus::kOk);
  ASSERT_EQ(device.activate(clock), DeviceStatus::kOk);
  for (int i = 0; i < reads; ++i) ASSERT_EQ(device.read(reading), DeviceStatus::kOk);
}

// A code outside hl_device_status is the call's failure, named with the
// call; only a trial's first failure is named (the calls after it are the
// loop's shutdown), and a new activate() starts afresh.
TEST(PluginDeviceTest, AnUnknownStatusIsNamedForTheTrialsFirstFailureOnly) {
  PluginDevice device(kFake, {{"fault", "unknown_status"}, {"after", "3"}});
  VirtualClock clock;
  DeviceReading reading;
  ASSERT_NO_FATAL_FAILURE(start_and_read(device, clock, 3, reading));
  EXPECT_EQ(device.status_detail(), "");
  EXPECT_EQ(device.read(reading), DeviceStatus::kReadFailed);
  const std::string named = "the plugin's read returned 42, which is no hl_device_status (taken as read_failed)";
  EXPECT_EQ(device.status_detail(), named);
  EXPECT_EQ(device.write(DeviceCommand{}), DeviceStatus::kOk);
  EXPECT_EQ(device.deactivate(), DeviceStatus::kOk);
  EXPECT_EQ(device.status_detail(), named);
  ASSERT_EQ(device.activate(clock), DeviceStatus::kOk);
  EXPECT_EQ(device.status_detail(), "");

  // A first failure with a code of the ABI has nothing more to say, and
  // hides no later code.
  PluginDevice ended(kFake, {{"fault", "end_of_data"}, {"after", "0"}});
  ASSERT_NO_FATAL_FAILURE(start_and_read(ended, clock, 0, reading));
  EXPECT_EQ(ended.read(reading), DeviceStatus::kEndOfData);
  EXPECT_EQ(ended.status_detail(), "");
  EXPECT_EQ(ended.unknown_status().op, -1);
}

// A read() that answers OK without writing the reading passed on whatever
// the stack held: garbage, or often the last reading (a tool that seems
// still while force is commanded). It is a non-finite reading, a fault.
TEST(PluginDeviceTest, AReadThatFillsNothingIsAFaultNotTheLastReading) {
  PluginDevice device(kFake, {{"fault", "unfilled_read"}, {"after", "3"}});
  VirtualClock clock;
  DeviceReading reading;
  ASSERT_NO_FATAL_FAILURE(start_and_read(device, clock, 3, reading));
  EXPECT_EQ(device.read(reading), DeviceStatus::kNonFiniteReading);
}

TEST(PluginDeviceTest, ANanReadingIsAFaultEvenWhenThePluginSaysOk) {
  PluginDevice device(kFake, {{"fault", "nan_read"}});
  VirtualClock clock;
  ASSERT_EQ(device.configure({}), DeviceStatus::kOk);
  ASSERT_EQ(device.activate(clock), DeviceStatus::kOk);
  DeviceReading reading;
  EXPECT_EQ(device.read(reading), DeviceStatus::kNonFiniteReading);
}

TEST(PluginDeviceTest, ANonFiniteCommandNeverReachesThePluginAForceBeyondPeakIsClippedHaltPassesThrough) {
  const fs::path report = temp_path("report.txt");
  {
    PluginDevice device(kFake, {{"report", report.string()}});
    VirtualClock clock;
    ASSERT_EQ(device.configure({}), DeviceStatus::kOk);
    EXPECT_EQ(device.hand_attachment(), nullptr);  // hardware: no simulation extension
    ASSERT_EQ(device.activate(clock), DeviceStatus::kOk);
    DeviceCommand command;
    command.force[1][kJointYaw] = std::numeric_limits<double>::infinity();
    command.force[0][kJointInsertion] = 2.0;
    EXPECT_EQ(device.write(command), DeviceStatus::kWriteFailed);  // sent as zero force
    command.force[1][kJointYaw] = 0.0;
    EXPECT_EQ(device.write(command), DeviceStatus::kOk);  // sent, clipped to the fake's peak 0.2 N
    device.halt();
  }  // destroy writes the report
  const std::string text = slurp(report);
  fs::remove(report);
  EXPECT_EQ(text, "writes 2 nonzero_writes 1 max_abs_force 0.2 halts 1\n");
}

TEST(PluginDeviceTest, NotCalibratedComesBackFromActivate) {
  PluginDevice device(kFake, {{"fault", "not_calibrated"}});
  VirtualClock clock;
  ASSERT_EQ(device.configure({}), DeviceStatus::kOk);
  EXPECT_EQ(device.activate(clock), DeviceStatus::kNotCalibrated);
}

TEST(PluginProbeTest, AWorkingPluginPasses) {
  EXPECT_NO_THROW(probe_plugin(kSimPlugin, {}, DeviceConfig{}));
  EXPECT_NO_THROW(probe_plugin(kFake, {{"fault", "nan_read"}}, DeviceConfig{}));  // only reads fail
}

TEST(PluginProbeTest, ACrashInConfigureIsNamedWithItsSignal) {
  EXPECT_EQ(thrown<std::runtime_error>([] { probe_plugin(kFake, {{"fault", "crash_in_configure"}}, DeviceConfig{}); }),
            "plugin " + kFake + " crashed (SIGSEGV) in configure; nothing was started");
}

TEST(PluginProbeTest, AnExitInCreateIsNamedWithItsStatus) {
  EXPECT_EQ(thrown<std::runtime_error>([] { probe_plugin(kFake, {{"fault", "exit_in_create"}}, DeviceConfig{}); }),
            "plugin " + kFake + " ended the process (exit status 7) in create; nothing was started");
}

TEST(PluginProbeTest, AHangInConfigureIsCutOffAfterTheTimeout) {
  EXPECT_EQ(thrown<std::runtime_error>(
                [] { probe_plugin(kFake, {{"fault", "hang_in_configure"}}, DeviceConfig{}, 0.3); }),
            "plugin " + kFake + " did not return from configure within 0.3 s; nothing was started");
}

TEST(PluginProbeTest, TheLoadersOwnMessagesComeBackFromTheChild) {
  EXPECT_THAT(thrown<std::runtime_error>([] { probe_plugin(kFakeAbi2, {}, DeviceConfig{}); }),
              HasSubstr("was built for device ABI 2, this HapticLab supports 1"));
  EXPECT_THAT(thrown<std::runtime_error>([] { probe_plugin(kFake, {{"fault", "invalid_ratings"}}, DeviceConfig{}); }),
              HasSubstr("right grip peak_force 0.05 must be >= continuous_force 0.1"));
  EXPECT_THAT(thrown<std::runtime_error>([] { probe_plugin(kFake, {{"colour", "red"}}, DeviceConfig{}); }),
              HasSubstr("'colour' is not an option of the fake device"));
}

// A fork of a process with other threads inherits the locks they hold (the
// allocator's, the loader's) and can hang on one: the forked probe refuses
// such a process by name rather than blame the plugin for a hang.
TEST(PluginProbeTest, TheForkedProbeRefusesAProcessWithOtherThreads) {
  std::promise<void> release;
  std::thread waiting([done = release.get_future()] { done.wait(); });
  const std::string refusal = thrown<std::runtime_error>([] { probe_plugin(kFake, {}, DeviceConfig{}); });
  release.set_value();
  waiting.join();
  EXPECT_EQ(refusal, "plugin " + kFake +
                         ": cannot probe it in a fork of this process, which runs 2 threads (a lock another thread "
                         "holds would hang the copy); register a plugin host (set_plugin_host_executable), as the "
                         "hapticlab command does; nothing was started");
  EXPECT_NO_THROW(probe_plugin(kFake, {}, DeviceConfig{}));  // alone again
}

TEST(PluginProbeTest, OpenDeviceLoadsAPluginSpec) {
  DeviceSpec spec = parse_device_spec("plugin:" + kSimPlugin);
  const std::unique_ptr<Device> device = open_device(spec);
  EXPECT_STREQ(device->name(), "sim-plugin");
}

}  // namespace
}  // namespace hapticlab
