#include "core/device/replay_device.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <unistd.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/common/random.h"
#include "core/device/trajectory_csv.h"
#include "core/common/clock.h"

namespace hapticlab {
namespace {

// Bit-for-bit equality, NaN included.
bool same_bits(const std::array<DeviceJoints, 2>& a, const std::array<DeviceJoints, 2>& b) {
  return std::memcmp(a.data(), b.data(), sizeof(a)) == 0;
}

// Frames at t = 10 s + k/1024 s (exactly representable), positions with all
// 53 bits of mantissa in use.
std::vector<ReplayFrame> random_frames(int n) {
  Random rng(42);
  std::vector<ReplayFrame> frames(n);
  for (int k = 0; k < n; ++k) {
    frames[k].t_s = 10.0 + k / 1024.0;
    for (auto& q : frames[k].position) {
      for (double& x : q) x = rng.uniform(-1.0, 1.0);
    }
  }
  return frames;
}

TEST(ReplayDeviceTest, RefusesEmptyUnsortedOrNonFiniteFrames) {
  EXPECT_THAT([] { ReplayDevice d({}); },
              testing::ThrowsMessage<std::invalid_argument>(testing::HasSubstr("empty")));
  std::vector<ReplayFrame> frames = random_frames(4);
  frames[2].t_s = 9.0;
  EXPECT_THAT([&] { ReplayDevice d(frames); },
              testing::ThrowsMessage<std::invalid_argument>(testing::HasSubstr("frame 2 has t_s = 9")));
  frames[2].t_s = std::nan("");
  EXPECT_THROW(ReplayDevice{frames}, std::invalid_argument);
}

TEST(ReplayDeviceTest, LifecycleStatuses) {
  VirtualClock clock;
  ReplayDevice device(random_frames(3));
  DeviceReading reading;
  EXPECT_STREQ(device.name(), "replay");
  EXPECT_EQ(device.read(reading), DeviceStatus::kNotActive);
  EXPECT_EQ(device.write({}), DeviceStatus::kNotActive);
  EXPECT_EQ(device.activate(clock), DeviceStatus::kNotConfigured);
  EXPECT_EQ(device.configure({.nominal_rate_Hz = 100.0}), DeviceStatus::kInvalidConfig);
  EXPECT_EQ(device.activate(clock), DeviceStatus::kNotConfigured);
  EXPECT_EQ(device.configure({.nominal_rate_Hz = 500.0}), DeviceStatus::kOk);
  EXPECT_EQ(device.activate(clock), DeviceStatus::kOk);
  EXPECT_EQ(device.read(reading), DeviceStatus::kOk);
  EXPECT_EQ(device.deactivate(), DeviceStatus::kOk);
  EXPECT_EQ(device.read(reading), DeviceStatus::kNotActive);
}

TEST(ReplayDeviceTest, ReturnsTheRecordedPositionsExactlyThenEndOfData) {
  const std::vector<ReplayFrame> frames = random_frames(5);  // 0 .. 4/1024 s
  VirtualClock clock;
  clock.sleep_until(3.0);  // playback starts at an arbitrary clock time
  ReplayDevice device(frames);
  ASSERT_EQ(device.configure({}), DeviceStatus::kOk);
  ASSERT_EQ(device.activate(clock), DeviceStatus::kOk);
  EXPECT_EQ(device.duration_s(), 4.0 / 1024.0);

  DeviceReading reading;
  struct Probe {
    double elapsed_s;
    int frame;
  };
  // At a frame's own time that frame is current (<=); between frames, the earlier one.
  const Probe probes[] = {{0.0, 0},          {0.5 / 1024, 0}, {1.0 / 1024, 1}, {1.999 / 1024, 1},
                          {2.0 / 1024, 2},   {3.7 / 1024, 3}, {4.0 / 1024, 4}};
  for (const Probe& p : probes) {
    clock.sleep_until(3.0 + p.elapsed_s);
    ASSERT_EQ(device.read(reading), DeviceStatus::kOk) << p.elapsed_s;
    EXPECT_TRUE(same_bits(reading.position, frames[p.frame].position)) << p.elapsed_s;
    EXPECT_EQ(reading.device_time_s, frames[p.frame].t_s);
  }
  clock.sleep_until(3.0 + 4.01 / 1024);
  EXPECT_EQ(device.read(reading), DeviceStatus::kEndOfData);
  EXPECT_TRUE(same_bits(reading.position, frames[4].position));
  clock.sleep_until(100.0);
  EXPECT_EQ(device.read(reading), DeviceStatus::kEndOfData);
  EXPECT_TRUE(same_bits(reading.position, frames[4].position));

  // Reactivating plays from the start again.
  ASSERT_EQ(device.deactivate(), DeviceStatus::kOk);
  ASSERT_EQ(device.activate(clock), DeviceStatus::kOk);
  EXPECT_EQ(device.read(reading), DeviceStatus::kOk);
  EXPECT_TRUE(same_bits(reading.position, frames[0].position));
}

TEST(ReplayDeviceTest, SkipsFramesWhenTheLoopIsSlowerAndTakesTheLastOfEqualTimes) {
  std::vector<ReplayFrame> frames = random_frames(6);
  frames[3].t_s = frames[2].t_s;  // two frames at one time: the later wins
  VirtualClock clock;
  ReplayDevice device(frames);
  ASSERT_EQ(device.configure({}), DeviceStatus::kOk);
  ASSERT_EQ(device.activate(clock), DeviceStatus::kOk);
  DeviceReading reading;
  clock.sleep_until(2.5 / 1024);
  ASSERT_EQ(device.read(reading), DeviceStatus::kOk);
  EXPECT_TRUE(same_bits(reading.position, frames[3].position));
}

TEST(ReplayDeviceTest, RecordedNonFiniteValueIsPassedOnAndReported) {
  std::vector<ReplayFrame> frames = random_frames(2);
  frames[1].position[1][2] = std::nan("");
  VirtualClock clock;
  ReplayDevice device(frames);
  ASSERT_EQ(device.configure({}), DeviceStatus::kOk);
  ASSERT_EQ(device.activate(clock), DeviceStatus::kOk);
  DeviceReading reading;
  clock.sleep_until(1.0 / 1024);
  EXPECT_EQ(device.read(reading), DeviceStatus::kNonFiniteReading);
  EXPECT_TRUE(same_bits(reading.position, frames[1].position));
}

TEST(ReplayDeviceTest, WriteRecordsTheCommand) {
  VirtualClock clock;
  ReplayDevice device(random_frames(2));
  ASSERT_EQ(device.configure({}), DeviceStatus::kOk);
  ASSERT_EQ(device.activate(clock), DeviceStatus::kOk);
  DeviceCommand c;
  c.force[1][kJointPitch] = 0.25;
  EXPECT_EQ(device.write(c), DeviceStatus::kOk);
  EXPECT_EQ(device.last_command().force[1][kJointPitch], 0.25);
  EXPECT_EQ(device.last_command().force[0][kJointInsertion], 0.0);
}

// A scratch directory for one test, removed afterwards.
class ScratchDir {
 public:
  ScratchDir()
      : path_(std::filesystem::temp_directory_path() /
              ("hapticlab_replay_test_" + std::to_string(::getpid()) + "_" +
               testing::UnitTest::GetInstance()->current_test_info()->name())) {
    std::filesystem::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  std::filesystem::path write(const std::string& name, const std::string& text) const {
    const std::filesystem::path file = path_ / name;
    std::ofstream(file) << text;
    return file;
  }

 private:
  std::filesystem::path path_;
};

TEST(ReplayDeviceTest, LoadsInterleavedEngineCsvIntoFramesAtEachDistinctTime) {
  ScratchDir dir;
  // Instrument 1 starts first; instrument 0's first row is at 0.002 s. Rows
  // are out of global time order (0.003 before 0.0025), as two instruments'
  // updates may be.
  const auto file = dir.write("trial.csv",
                              "t_s,instrument,insertion_m,pitch_rad,yaw_rad,ve_force_x_N,ve_force_y_N,ve_force_z_N\n"
                              "0.001,1,0.05,0.1,0.2,0,0,0\n"
                              "0.002,0,0.06,-0.1,0.3,1,2,3\n"
                              "0.002,1,0.051,0.11,0.21,0,0,0\n"
                              "0.003,0,0.07,-0.12,0.31,0,0,0\n"
                              "0.0025,1,0.052,0.12,0.22,0,0,0\n");
  const std::vector<ReplayFrame> frames = load_replay_frames_from_trajectory_csv(file);
  ASSERT_EQ(frames.size(), 4u);
  const double times[] = {0.001, 0.002, 0.0025, 0.003};
  const DeviceJoints left[] = {{0.06, -0.1, 0.3, 0, 0},  // holds its first recorded position
                               {0.06, -0.1, 0.3, 0, 0},
                               {0.06, -0.1, 0.3, 0, 0},
                               {0.07, -0.12, 0.31, 0, 0}};
  const DeviceJoints right[] = {{0.05, 0.1, 0.2, 0, 0},
                                {0.051, 0.11, 0.21, 0, 0},
                                {0.052, 0.12, 0.22, 0, 0},
                                {0.052, 0.12, 0.22, 0, 0}};
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(frames[k].t_s, times[k]);
    EXPECT_EQ(frames[k].position[0], left[k]) << k;
    EXPECT_EQ(frames[k].position[1], right[k]) << k;
  }

  // And plays them back.
  VirtualClock clock;
  ReplayDevice device(frames);
  ASSERT_EQ(device.configure({}), DeviceStatus::kOk);
  ASSERT_EQ(device.activate(clock), DeviceStatus::kOk);
  DeviceReading reading;
  clock.sleep_until(0.0012);
  EXPECT_EQ(device.read(reading), DeviceStatus::kOk);
  EXPECT_EQ(reading.position[1], right[1]);
}

TEST(ReplayDeviceTest, MalformedOrEmptyCsvIsAnError) {
  ScratchDir dir;
  const std::string header =
      "t_s,instrument,insertion_m,pitch_rad,yaw_rad,ve_force_x_N,ve_force_y_N,ve_force_z_N\n";
  EXPECT_THROW(load_replay_frames_from_trajectory_csv(dir.write("empty.csv", header)),
               TrajectoryCsvError);
  EXPECT_THROW(load_replay_frames_from_trajectory_csv(dir.write("bad.csv", header + "0.001,2,0,0,0,0,0,0\n")),
               TrajectoryCsvError);
  EXPECT_ANY_THROW(load_replay_frames_from_trajectory_csv("/nonexistent/hapticlab/none.csv"));
}

// Each was replayed with exit 0: a missing instrument at zero (the tool at
// its pivot), and of two rows of one instrument at one time only the later.
TEST(ReplayDeviceTest, AMissingInstrumentOrTwoPositionsAtOneTimeAreRefusedByName) {
  ScratchDir dir;
  const std::string header =
      "t_s,instrument,insertion_m,pitch_rad,yaw_rad,ve_force_x_N,ve_force_y_N,ve_force_z_N\n";
  const auto message = [&](const std::string& name, const std::string& rows) {
    try {
      load_replay_frames_from_trajectory_csv(dir.write(name, header + rows));
    } catch (const TrajectoryCsvError& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  EXPECT_THAT(message("one.csv", "0.001,1,0.05,0.1,0.2,0,0,0\n0.002,1,0.05,0.1,0.2,0,0,0\n"),
              ::testing::HasSubstr("one.csv: instrument 0 has no rows; a replay moves both instruments"));
  EXPECT_THAT(message("twice.csv", "0.001,0,0.05,0.1,0.2,0,0,0\n0.001,1,0.05,0.1,0.2,0,0,0\n"
                                   "0.002,0,0.06,0.1,0.2,0,0,0\n0.002,0,0.07,0.1,0.2,0,0,0\n"),
              ::testing::HasSubstr("twice.csv:5: instrument 0 has a second row at t_s 0.002 (line 4 is the "
                                   "first); a replayed device shows one position at a time"));
}

}  // namespace
}  // namespace hapticlab
