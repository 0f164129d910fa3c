#include "app/engine/engine_replay.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/device/trajectory_csv.h"
#include "tests/testing/files.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;

using testing::has_temp_file;

constexpr double kDefaultFrictionLevel_N = 0.45;  // translation.friction default
constexpr double kForceTolerance_N = 1e-6;

// Friction on insertion only, every field at its default.
const char* const kFrictionSettings = R"({"name":"friction","translation":{"friction":{}}})";

const char* const kInputHeader =
    "t_s,instrument,insertion_m,pitch_rad,yaw_rad,ve_force_x_N,ve_force_y_N,ve_force_z_N\n";

class EngineReplayTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(::testing::TempDir()) / (std::string("engine_replay_test_") + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path write_file(const std::string& name, const std::string& text) const {
    const fs::path path = dir_ / name;
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }

  // `hapticlab engine replay ...`, in process, through CLI11.
  static std::string replay(const fs::path& settings, const fs::path& input,
                            const fs::path& output) {
    CLI::App app;
    CLI::App* engine = app.add_subcommand("engine");
    add_engine_replay_command(*engine);
    std::vector<std::string> args = {"engine",  "replay",         "--settings", settings.string(),
                                     "--csv", input.string(),   "--out",   output.string()};
    std::reverse(args.begin(), args.end());  // CLI11 takes the arguments last first
    ::testing::internal::CaptureStdout();
    try {
      app.parse(args);
    } catch (...) {
      ::testing::internal::GetCapturedStdout();
      throw;
    }
    return ::testing::internal::GetCapturedStdout();
  }

  fs::path dir_;
};

struct Csv {
  std::string header;
  std::vector<std::string> lines;
  std::vector<std::map<std::string, double>> rows;
};

Csv read_csv(const fs::path& path) {
  std::ifstream in(path);
  Csv csv;
  std::getline(in, csv.header);
  std::vector<std::string> names;
  std::istringstream h(csv.header);
  for (std::string name; std::getline(h, name, ',');) names.push_back(name);
  for (std::string line; std::getline(in, line);) {
    csv.lines.push_back(line);
    std::istringstream cells(line);
    std::map<std::string, double> row;
    std::size_t i = 0;
    for (std::string cell; std::getline(cells, cell, ',') && i < names.size(); ++i) {
      row[names[i]] = std::strtod(cell.c_str(), nullptr);
    }
    csv.rows.push_back(row);
  }
  return csv;
}

std::string row_text(double t_s, int instrument, double insertion_m, double pitch_rad = 0.0,
                     double yaw_rad = 0.0, double fz_N = 0.0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, "%.17g,%d,%.17g,%.17g,%.17g,0,0,%.17g\n", t_s, instrument,
                insertion_m, pitch_rad, yaw_rad, fz_N);
  return buf;
}

// Triangle wave: 0.10 m → 0.12 m → 0.10 m ... at `speed`.
double triangle_m(double t_s, double speed_m_per_s, double half_period_s) {
  const double phase = std::fmod(t_s, 2.0 * half_period_s);
  const double s = phase < half_period_s ? phase : 2.0 * half_period_s - phase;
  return 0.10 + speed_m_per_s * s;
}

TEST_F(EngineReplayTest, FrictionOpposesInsertionVelocityAtTheSlipLevel) {
  const fs::path settings = write_file("friction.json", kFrictionSettings);
  const double dt_s = 0.001, speed = 0.02, half_period_s = 1.0;
  std::string text = kInputHeader;
  for (int k = 0; k <= 4000; ++k) {
    text += row_text(k * dt_s, 0, triangle_m(k * dt_s, speed, half_period_s));
  }
  const fs::path input = write_file("in.csv", text);
  const fs::path output = dir_ / "out.csv";

  const std::string summary = replay(settings, input, output);
  EXPECT_NE(summary.find("4001 rows (instrument 0: 4001, instrument 1: 0)"), std::string::npos)
      << summary;
  EXPECT_NE(summary.find("0 rows with faults"), std::string::npos) << summary;

  const Csv csv = read_csv(output);
  ASSERT_EQ(csv.rows.size(), 4001u);
  int checked = 0;
  for (const auto& row : csv.rows) {
    const double t = row.at("t_s");
    // Away from the reversals, where the velocity filter has settled.
    const double from_reversal_s = std::fmod(t, half_period_s);
    if (from_reversal_s < 0.1 || from_reversal_s > half_period_s - 0.01) continue;
    const bool inserting = std::fmod(t, 2.0 * half_period_s) < half_period_s;
    const double expected_N = inserting ? -kDefaultFrictionLevel_N : kDefaultFrictionLevel_N;
    ASSERT_NEAR(row.at("insertion_force_N"), expected_N, kForceTolerance_N) << "t = " << t;
    // At zero angles the tool points along −z: insertion force F_i shows as −F_i·z.
    ASSERT_NEAR(row.at("displayed_force_z_N"), -expected_N, kForceTolerance_N) << "t = " << t;
    ASSERT_EQ(row.at("fault"), 0.0);
    ++checked;
  }
  EXPECT_GT(checked, 3000);
}

// The trajectory the README's "Using the engine" replays: at High Fidelity
// the device shows the VE's tissue force as is, 300 N/m x 5 mm = 1.5 N up
// the shaft at the deepest point, and nothing on the resting left tool.
TEST_F(EngineReplayTest, TheShippedExampleTrajectoryReplays) {
  const fs::path source = HAPTICLAB_SOURCE_DIR;
  const fs::path out = dir_ / "out.csv";
  replay(source / "examples/settings/high_fidelity.json", source / "examples/trajectories/probe_and_press.csv", out);
  const Csv csv = read_csv(out);
  ASSERT_EQ(csv.rows.size(), 2002u);
  double peak_right_N = 0.0, peak_left_N = 0.0;
  for (const auto& row : csv.rows) {
    double& peak = row.at("instrument") == 1.0 ? peak_right_N : peak_left_N;
    peak = std::max(peak, row.at("displayed_force_z_N"));
  }
  EXPECT_NEAR(peak_right_N, 1.5, 1e-6);
  EXPECT_EQ(peak_left_N, 0.0);
}

TEST_F(EngineReplayTest, OutputHasTheDocumentedColumnsInOrder) {
  const fs::path settings = write_file("s.json", R"({"name":"hi-fi"})");
  const fs::path input = write_file(
      "in.csv",
      "ve_force_z_N,t_s,instrument,insertion_m,pitch_rad,yaw_rad,ve_force_x_N,ve_force_y_N\n"
      "1,0,1,0.1,0,0,0,0\n");
  const fs::path output = dir_ / "out.csv";
  replay(settings, input, output);
  const Csv csv = read_csv(output);
  EXPECT_EQ(csv.header,
            "t_s,instrument,insertion_m,pitch_rad,yaw_rad,ve_force_x_N,ve_force_y_N,ve_force_z_N,"
            "displayed_force_x_N,displayed_force_y_N,displayed_force_z_N,insertion_force_N,"
            "pitch_torque_Nm,yaw_torque_Nm,degraded_insertion_m,degraded_pitch_rad,"
            "degraded_yaw_rad,fault");
  ASSERT_EQ(csv.rows.size(), 1u);
  EXPECT_EQ(csv.rows[0].at("instrument"), 1.0);
  EXPECT_EQ(csv.rows[0].at("ve_force_z_N"), 1.0);
  EXPECT_FALSE(has_temp_file(dir_));
}

TEST_F(EngineReplayTest, MalformedInputThrowsAndLeavesNoOutput) {
  const fs::path settings = write_file("s.json", kFrictionSettings);
  // Both instruments appear before the bad line, so the replay itself (not
  // only the scan for start positions) has started writing when it fails.
  const fs::path input = write_file("in.csv", std::string(kInputHeader) + row_text(0, 0, 0.1) +
                                                  row_text(0, 1, 0.1) +
                                                  "0.001,0,0.1,zero,0,0,0,0\n" +
                                                  row_text(0.002, 0, 0.1));
  const fs::path output = dir_ / "out.csv";
  try {
    replay(settings, input, output);
    FAIL() << "no exception";
  } catch (const std::exception& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("line 4"), std::string::npos) << msg;
    EXPECT_NE(msg.find("'zero'"), std::string::npos) << msg;
  }
  EXPECT_FALSE(fs::exists(output));
  EXPECT_FALSE(has_temp_file(dir_));
}

TEST_F(EngineReplayTest, EachInstrumentHasItsOwnClock) {
  // Inertia and friction make the output depend on every dt the instrument saw.
  const fs::path settings = write_file(
      "s.json", R"({"name":"mix","translation":{"friction":{},"inertia":{}},)"
                R"("rotation":{"friction":{},"inertia":{}}})");
  std::string interleaved = kInputHeader, solo = kInputHeader;
  for (int k = 0; k <= 2000; ++k) {
    const double t0 = k * 0.001;  // instrument 0 at 1 kHz
    interleaved += row_text(t0, 0, triangle_m(t0, 0.03, 0.5), 0.1 * std::sin(3 * t0));
    if (k % 2 == 1) {  // instrument 1 at 500 Hz, between instrument 0's rows
      const double t1 = 0.0005 + k * 0.001;
      const std::string row =
          row_text(t1, 1, triangle_m(t1, 0.02, 0.7), 0.2 * std::sin(2 * t1), 0.1 * std::cos(5 * t1),
                   -0.5 * std::sin(t1));
      interleaved += row;
      solo += row;
    }
  }
  const fs::path out_interleaved = dir_ / "interleaved_out.csv";
  const fs::path out_solo = dir_ / "solo_out.csv";
  const std::string summary =
      replay(settings, write_file("interleaved.csv", interleaved), out_interleaved);
  EXPECT_NE(summary.find("3001 rows (instrument 0: 2001, instrument 1: 1000)"), std::string::npos)
      << summary;
  replay(settings, write_file("solo.csv", solo), out_solo);

  std::vector<std::string> instrument1;
  for (const std::string& line : read_csv(out_interleaved).lines) {
    if (line.find(",1,") == line.find(',')) instrument1.push_back(line);
  }
  const Csv solo_csv = read_csv(out_solo);
  ASSERT_EQ(instrument1.size(), 1000u);
  EXPECT_EQ(instrument1, solo_csv.lines);  // bit-identical, every column

  // The test means something only if the forces actually vary.
  double min_N = 1e9, max_N = -1e9;
  for (const auto& row : solo_csv.rows) {
    min_N = std::min(min_N, row.at("insertion_force_N"));
    max_N = std::max(max_N, row.at("insertion_force_N"));
  }
  EXPECT_GT(max_N - min_N, 0.5);
}

// Each of these exited 0 before: a t_s in milliseconds (every row
// re-anchored, the VE force passed through undegraded: 0 N through a
// saturation, "0 rows with faults"), a pipe (read twice: the second read
// began mid-stream, "no header line"), and a header without rows (an output
// of a header alone).
TEST_F(EngineReplayTest, TimesNotInSecondsAPipeAndNoRowsAreRefusedByName) {
  const fs::path settings = write_file("s.json", kFrictionSettings);
  std::string seconds = kInputHeader, milliseconds = kInputHeader;
  for (int k = 0; k <= 200; ++k) {
    const double t_s = k * 0.002;
    seconds += row_text(t_s, 0, triangle_m(t_s, 0.03, 0.2), 0.0, 0.0, -0.5);
    milliseconds += row_text(1000.0 * t_s, 0, triangle_m(t_s, 0.03, 0.2), 0.0, 0.0, -0.5);
  }
  const fs::path output = dir_ / "out.csv";
  const auto refusal = [&](const fs::path& input) {
    try {
      replay(settings, input, output);
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };

  const std::string ms = refusal(write_file("ms.csv", milliseconds));
  EXPECT_NE(ms.find("200 of the 200 rows"), std::string::npos) << ms;
  EXPECT_NE(ms.find("median time step is 2 s"), std::string::npos) << ms;
  EXPECT_NE(ms.find("Is t_s in seconds?"), std::string::npos) << ms;
  EXPECT_FALSE(fs::exists(output));

  // One gap in an otherwise steady recording is replayed, and counted.
  std::string one_gap = seconds;
  one_gap += row_text(1.0, 0, 0.1);
  const std::string summary = replay(settings, write_file("gap.csv", one_gap), output);
  EXPECT_NE(summary.find("1 rows re-anchored after a gap of more than 8/150 s"), std::string::npos) << summary;
  EXPECT_EQ(replay(settings, write_file("s.csv", seconds), output).find("re-anchored"), std::string::npos);

  const fs::path fifo = dir_ / "pipe.csv";
  ASSERT_EQ(std::system(("mkfifo '" + fifo.string() + "'").c_str()), 0);
  const std::string pipe = refusal(fifo);
  EXPECT_NE(pipe.find("not a regular file"), std::string::npos) << pipe;
  EXPECT_NE(pipe.find("--csv " + fifo.string()), std::string::npos) << pipe;

  const std::string overflow =
      refusal(write_file("overflow.csv", std::string(kInputHeader) + row_text(-1e308, 0, 0.1) + row_text(1e308, 0, 0.1)));
  EXPECT_NE(overflow.find("instrument 0's t_s goes from -1e+308 to 1e+308, a step too large for a double"),
            std::string::npos)
      << overflow;

  fs::remove(output);
  const std::string empty = refusal(write_file("empty.csv", kInputHeader));
  EXPECT_NE(empty.find("a header and no rows"), std::string::npos) << empty;
  EXPECT_FALSE(fs::exists(output));
  EXPECT_FALSE(has_temp_file(dir_));
}

}  // namespace
}  // namespace hapticlab::app
