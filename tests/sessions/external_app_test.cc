// Issue 15 section 3, end to end with real processes: the study is created
// with the CLI from examples/protocols/external_peg_touch.json (an external
// VE, the lab's own task "peg touch"); examples/external_app runs it through
// the study API, is killed with SIGKILL mid-trial, runs again, and the
// database holds what `session run` would have left: no trial lost or
// duplicated, the killed one aborted and re-queued with its samples kept,
// the study checks clean, and `hapticlab analyze` computes the metrics of
// the lab's task from the toy VE's events.
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "testing/csv_rows.h"
#include "tests/app/cli_process.h"
#include "db/study_db.h"
#include "tests/testing/child_process.h"

namespace hapticlab::sessions {
namespace {

using ::testing::HasSubstr;
using Clock = std::chrono::steady_clock;

std::filesystem::path source_dir() {
  if (const char* env = std::getenv("HAPTICLAB_SOURCE_DIR")) return env;
  return HAPTICLAB_SOURCE_DIR;
}

db::StudyDb open_read_only(const std::filesystem::path& path) {
  db::OpenOptions o;
  o.recover = false;
  o.read_only = true;
  o.integrity = db::OpenOptions::Integrity::kSkip;
  return db::StudyDb(path, o);
}

class ExternalAppTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("hapticlab_external_app_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    db_ = dir_ / "study.db";
  }
  void TearDown() override {
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }
  std::filesystem::path dir_, db_;
};

TEST_F(ExternalAppTest, KilledMidTrialResumesAndTheLabsTaskIsAnalysed) {
  const auto [created, create_out] = hapticlab::testing::run_cli(
      HAPTICLAB_CLI_PATH, "study create --protocol " +
                              (source_dir() / "examples/protocols/external_peg_touch.json").string() + " --db " +
                              db_.string());
  ASSERT_EQ(created, 0) << create_out;

  // Run 1: the VE freezes after 400 updates of the first trial; once those
  // are in the database (the writer commits within ~55 ms), kill -9.
  constexpr std::uint64_t kStallAfter = 400;
  std::int64_t killed_trial = 0;
  {
    hapticlab::testing::ChildProcess app({HAPTICLAB_EXTERNAL_APP_PATH, db_.string(), "P01", "--stall-after",
                               std::to_string(kStallAfter)},
                              (dir_ / "run1.log").string());
    const Clock::time_point give_up = Clock::now() + std::chrono::seconds(20);
    std::string out;
    while (Clock::now() < give_up && (out = app.output()).find("stalled in trial") == std::string::npos) {
      ASSERT_TRUE(app.running()) << out;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ASSERT_THAT(out, HasSubstr("stalled in trial"));
    killed_trial = std::stoll(out.substr(out.find("stalled in trial ") + 17));
    std::uint64_t stored = 0;
    while (Clock::now() < give_up && stored < kStallAfter) {
      stored = open_read_only(db_).sample_count(killed_trial, 0);
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ASSERT_EQ(stored, kStallAfter);
    app.kill(SIGKILL);
    EXPECT_EQ(app.wait(), -SIGKILL);
  }

  // Run 2: resumes and finishes the participant's schedule.
  {
    hapticlab::testing::ChildProcess app({HAPTICLAB_EXTERNAL_APP_PATH, db_.string(), "P01"}, (dir_ / "run2.log").string());
    EXPECT_EQ(app.wait(), 0) << app.output();
    EXPECT_THAT(app.output(), HasSubstr("previous session had died"));
    EXPECT_THAT(app.output(), HasSubstr("schedule complete"));
  }

  {
    db::StudyDb db = open_read_only(db_);
    std::map<int, int> complete_at;  // position -> complete trials there
    int aborted = 0;
    for (const db::TrialRow& t : db.trials()) {
      if (t.participant_code != "P01") continue;
      EXPECT_EQ(t.task, "peg touch");
      EXPECT_NE(t.status, db::TrialStatus::kPlanned);
      EXPECT_NE(t.status, db::TrialStatus::kRunning);
      if (t.status == db::TrialStatus::kComplete) {
        ++complete_at[t.position];
        // 792 updates: the third touch ends at update 791 (see below).
        EXPECT_EQ(db.sample_count(t.id, 0), 792u) << "trial " << t.id;
        EXPECT_EQ(db.sample_count(t.id, 1), 792u) << "trial " << t.id;
      } else {
        ++aborted;
        EXPECT_EQ(t.id, killed_trial);
        EXPECT_EQ(t.abort_reason, db::kInterruptedReason);
        EXPECT_EQ(db.sample_count(t.id, 0), kStallAfter);  // kept
      }
    }
    EXPECT_EQ(aborted, 1);
    EXPECT_EQ(complete_at, (std::map<int, int>{{1, 1}, {2, 1}, {3, 1}, {4, 1}}));  // none lost, none twice
    EXPECT_EQ(db.trial(killed_trial).position, 1);
    EXPECT_EQ(db.session(1).status, db::SessionStatus::kInterrupted);  // the killed run
    EXPECT_EQ(db.session(2).status, db::SessionStatus::kClosed);
  }

  const auto [checked, check_out] = hapticlab::testing::run_cli(HAPTICLAB_CLI_PATH, "study check --db " + db_.string());
  EXPECT_EQ(checked, 0) << check_out;
  const std::filesystem::path out = dir_ / "analysis";
  const auto [analysed, analyse_out] = hapticlab::testing::run_cli(
      HAPTICLAB_CLI_PATH, "analyze --no-plots --no-ks --quiet --db " + db_.string() + " --out " + out.string());
  ASSERT_EQ(analysed, 0) << analyse_out;

  // The toy VE's scripted hand moves the left tool 0.1 mm per 1 ms update:
  //   insertion_passed_20mm at update 100 (10.05 mm + 0.1 mm x 100 = 20.05 mm),
  //   touches while insertion > 45 mm: updates 350-430, 530-610, 710-790;
  //   the third contact_end (task_complete) at update 791.
  // completion = 0.791 s - 0.100 s; path length = 691 steps x 0.1 mm;
  // speed 0.1 m/s throughout. Force 200 N/m x (insertion - 45 mm) in contact:
  // per touch 0.01, 0.03, ..., 0.81, ..., 0.01 N (81 samples, 0.81 once),
  // 243 in all; the median (122nd) is 0.41 N, the 95th percentile (type 5,
  // rank 231.35) 0.77 N. Samples are stored as float32: tolerance 1e-6
  // relative (float's 6e-8, summed over the path's steps).
  int rows = 0;
  for (const auto& row : hapticlab::testing::read_csv_rows(out / "metrics.csv")) {
    if (row.at("instrument") != "0") continue;
    ++rows;
    EXPECT_EQ(row.at("task"), "peg touch");
    EXPECT_EQ(row.at("status"), "complete");
    EXPECT_NEAR(std::stod(row.at("task_start_s")), 0.100, 1e-12);
    EXPECT_NEAR(std::stod(row.at("completion_time_s")), 0.691, 1e-12);
    EXPECT_EQ(row.at("force_samples"), "243");
    EXPECT_NEAR(std::stod(row.at("force_median_N")), 0.41, 0.41 * 1e-6);
    EXPECT_NEAR(std::stod(row.at("force_p95_N")), 0.77, 0.77 * 1e-6);
    EXPECT_NEAR(std::stod(row.at("speed_median_m_per_s")), 0.1, 0.1 * 1e-6);
    EXPECT_NEAR(std::stod(row.at("path_length_m")), 0.0691, 0.0691 * 1e-6);
  }
  EXPECT_EQ(rows, 4);  // complete trials only: the killed one is left out by default
}

}  // namespace
}  // namespace hapticlab::sessions
