// `hapticlab sim run`, in process through CLI11: the CSV it writes (the
// documented columns, one row per loop update, events in the last column),
// the one-line summary, the exit status, and errors that name the bad value.
#include "app/engine/sim_run.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include "tests/testing/files.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;

using testing::has_temp_file;

fs::path shipped_settings(const std::string& name) {
  return fs::path(HAPTICLAB_SOURCE_DIR) / "examples" / "settings" / (name + ".json");
}

// The columns core/loop/loop_sample_csv.h documents, written out by hand:
// the long layout of every sample table (export's, after its trial key).
std::vector<std::string> documented_columns() {
  return {"instrument", "tick", "dt_s", "t_s", "raw_insertion_m", "raw_pitch_rad", "raw_yaw_rad", "raw_twist_rad",
          "raw_grip_rad", "degraded_insertion_m", "degraded_pitch_rad", "degraded_yaw_rad", "tip_x_m", "tip_y_m",
          "tip_z_m", "tip_vx_m_per_s", "tip_vy_m_per_s", "tip_vz_m_per_s", "ve_force_x_N", "ve_force_y_N",
          "ve_force_z_N", "displayed_force_x_N", "displayed_force_y_N", "displayed_force_z_N", "insertion_force_N",
          "pitch_torque_Nm", "yaw_torque_Nm", "engine_status", "device_status", "in_contact", "events"};
}

std::vector<std::string> split(const std::string& line, char sep) {
  std::vector<std::string> out;
  std::string cell;
  std::istringstream in(line);
  while (std::getline(in, cell, sep)) out.push_back(cell);
  if (!line.empty() && line.back() == sep) out.emplace_back();  // trailing empty cell
  return out;
}

struct SampleCsv {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  double number(std::size_t row, const std::string& column) const {
    const auto it = std::find(header.begin(), header.end(), column);
    EXPECT_NE(it, header.end()) << column;
    return std::strtod(rows[row][static_cast<std::size_t>(it - header.begin())].c_str(), nullptr);
  }
};

SampleCsv read_sample_csv(const fs::path& path) {
  std::ifstream in(path);
  SampleCsv csv;
  std::string line;
  std::getline(in, line);
  csv.header = split(line, ',');
  while (std::getline(in, line)) csv.rows.push_back(split(line, ','));
  return csv;
}

class SimRunTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(::testing::TempDir()) / (std::string("sim_run_test_") + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // `hapticlab sim run ARGS...`; returns what it printed on stdout.
  static std::string sim_run(std::vector<std::string> args) {
    CLI::App app;
    CLI::App* sim = app.add_subcommand("sim");
    add_sim_run_command(*sim);
    args.insert(args.begin(), {"sim", "run"});
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

  // Runs the command expecting it to fail; returns the error message.
  std::string sim_run_error(const std::vector<std::string>& args) {
    try {
      sim_run(args);
    } catch (const std::exception& e) {
      return e.what();
    }
    ADD_FAILURE() << "no error";
    return {};
  }

  bool dir_is_empty() const { return fs::is_empty(dir_); }

  fs::path dir_;
};

TEST_F(SimRunTest, WritesOneRowPerUpdateWithTheDocumentedColumnsAndPrintsTheSummary) {
  const fs::path out = dir_ / "trial.csv";
  const std::string printed = sim_run({"--task", "dissection", "--settings",
                                       shipped_settings("high_fidelity").string(), "--participant-seed", "2",
                                       "--out", out.string()});
  const SampleCsv csv = read_sample_csv(out);
  EXPECT_EQ(csv.header, documented_columns());
  ASSERT_GT(csv.rows.size(), 2u * 5000u);  // a dissection takes seconds at 1 kHz
  ASSERT_EQ(csv.rows.size() % 2, 0u);
  // Every update, in order, 1 ms apart (the virtual clock keeps the fixed
  // 1 kHz schedule exactly up to the rounding of the summed periods); a row
  // per instrument, left first.
  double peak_N[2] = {0.0, 0.0};
  int complete = 0, removed = 0, insertion = 0;
  for (std::size_t k = 0; k < csv.rows.size(); ++k) {
    ASSERT_EQ(csv.rows[k].size(), csv.header.size()) << "row " << k;
    const std::size_t update = k / 2;
    const std::size_t i = k % 2;
    ASSERT_EQ(csv.number(k, "instrument"), static_cast<double>(i));
    ASSERT_EQ(csv.number(k, "tick"), static_cast<double>(update));
    ASSERT_NEAR(csv.number(k, "t_s"), 0.001 * static_cast<double>(update), 1e-9) << k;
    ASSERT_NEAR(csv.number(k, "dt_s"), 0.001, 1e-12) << k;
    ASSERT_EQ(csv.number(k, "device_status"), 0.0);
    const double f =
        std::hypot(csv.number(k, "ve_force_x_N"), csv.number(k, "ve_force_y_N"), csv.number(k, "ve_force_z_N"));
    peak_N[i] = std::max(peak_N[i], f);
    for (const std::string& e : split(csv.rows[k].back(), ';')) {
      complete += e == "task:task_complete" && i == 0;  // task-wide events: in the left row
      removed += e.rfind("right:tissue_removed#", 0) == 0 && i == 1;
      insertion += e == "right:insertion_passed_20mm" && i == 1;
    }
  }
  EXPECT_EQ(complete, 1);
  EXPECT_GT(removed, 10);
  EXPECT_GE(insertion, 1);

  // One line: task, setting, participant, outcome, duration, samples, peak
  // forces (the CSV's, to the printed 2 decimals), output path.
  ASSERT_FALSE(printed.empty());
  EXPECT_EQ(std::count(printed.begin(), printed.end(), '\n'), 1) << printed;
  const double last_t = csv.number(csv.rows.size() - 1, "t_s");
  char expected[512];
  std::snprintf(expected, sizeof expected,
                "dissection, High Fidelity, participant 2 (fitted population): complete after %.2f s (virtual clock), %zu "
                "samples, peak force left %.2f N right %.2f N -> %s\n",
                last_t, csv.rows.size() / 2, peak_N[0], peak_N[1], out.string().c_str());
  EXPECT_EQ(printed, expected);
  EXPECT_FALSE(has_temp_file(dir_));
}

TEST_F(SimRunTest, RateAndMaxDurationShapeTheFileAndATimeoutExitsWithTwo) {
  // 512 Hz (a period of 2^-9 s, so the summed periods are exact) for at
  // most 1.5 s of a clip trial: updates at k/512 s up to 1.5 s = 768/512,
  // 769 rows, then "max_duration" and exit status 2.
  const fs::path out = dir_ / "short.csv";
  ::testing::internal::CaptureStdout();
  int exit_code = 0;
  {
    CLI::App app;
    CLI::App* sim = app.add_subcommand("sim");
    add_sim_run_command(*sim);
    std::vector<std::string> args = {"sim", "run", "--task", "clip", "--settings",
                                     shipped_settings("friction").string(), "--rate-hz", "512",
                                     "--max-trial-s", "1.5", "--out", out.string()};
    std::reverse(args.begin(), args.end());
    try {
      app.parse(args);
    } catch (const CLI::RuntimeError& e) {
      exit_code = e.get_exit_code();
    }
  }
  const std::string printed = ::testing::internal::GetCapturedStdout();
  EXPECT_EQ(exit_code, 4);  // timed out: 2 is for usage errors
  EXPECT_NE(printed.find("clip, Friction, participant 1 (fitted population): max_duration after 1.50 s"), std::string::npos)
      << printed;
  const SampleCsv csv = read_sample_csv(out);
  ASSERT_EQ(csv.rows.size(), 2u * 769u);
  for (std::size_t k = 0; k < csv.rows.size(); ++k) {
    EXPECT_EQ(csv.number(k, "t_s"), static_cast<double>(k / 2) / 512.0);
    EXPECT_EQ(csv.number(k, "dt_s"), 1.0 / 512.0);
  }
  EXPECT_NE(printed.find("769 samples"), std::string::npos) << printed;
}

TEST_F(SimRunTest, BadTaskIsRefusedNamingTheValueAndTheChoices) {
  const std::string msg = sim_run_error({"--task", "suturing", "--settings",
                                         shipped_settings("high_fidelity").string(), "--out",
                                         (dir_ / "x.csv").string()});
  EXPECT_NE(msg.find("suturing"), std::string::npos) << msg;
  EXPECT_NE(msg.find("dissection"), std::string::npos) << msg;
  EXPECT_NE(msg.find("clip"), std::string::npos) << msg;
  EXPECT_TRUE(dir_is_empty());
}

TEST_F(SimRunTest, RateOutsideTheLoopsRangeIsRefusedNamingTheValue) {
  for (const std::string rate : {"5000", "100", "fast"}) {
    const std::string msg = sim_run_error({"--task", "clip", "--settings",
                                           shipped_settings("high_fidelity").string(), "--rate-hz", rate,
                                           "--out", (dir_ / "x.csv").string()});
    EXPECT_NE(msg.find(rate), std::string::npos) << msg;
    EXPECT_TRUE(dir_is_empty()) << rate;
  }
}

TEST_F(SimRunTest, MissingOrInvalidSettingsFileIsRefusedNamingIt) {
  const fs::path missing = dir_ / "no_such_settings.json";
  std::string msg = sim_run_error({"--settings", missing.string(), "--out", (dir_ / "x.csv").string()});
  EXPECT_NE(msg.find(missing.string()), std::string::npos) << msg;
  EXPECT_TRUE(dir_is_empty());

  // A file that exists but holds a value out of range: the settings loader
  // names the field and the value, and no output appears.
  const fs::path bad = dir_ / "bad.json";
  std::ofstream(bad) << R"({"name":"bad","tip_force_saturation":{"limit_N":-2.5}})";
  msg = sim_run_error({"--settings", bad.string(), "--out", (dir_ / "x.csv").string()});
  EXPECT_NE(msg.find("limit_N"), std::string::npos) << msg;
  EXPECT_NE(msg.find("-2.5"), std::string::npos) << msg;
  EXPECT_FALSE(fs::exists(dir_ / "x.csv"));
  EXPECT_FALSE(has_temp_file(dir_));
}

}  // namespace
}  // namespace hapticlab::app
