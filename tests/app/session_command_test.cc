// `study create`, `study show`, `session run` and `sim replay` through the
// real binary: what the operator sees, that a blind session never names a
// setting, and that a logged trial replays.
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/cli_process.h"
#include "testing/csv_rows.h"
#include "db/study_db.h"

#include <nlohmann/json.hpp>
#include "tests/testing/sqlite_edit.h"
#include "tests/testing/test_paths.h"

namespace hapticlab {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;


// The eight settings of the quick thesis protocol.
constexpr std::array<const char*, 8> kSettingNames = {
    "High Fidelity", "No Force Feedback", "All Degradations", "Inertia + Backlash",
    "Cogging",       "Friction",          "Inertia",          "Force Saturation"};

class SessionCommandTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("hapticlab_session_command_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    db_ = (dir_ / "study.db").string();
    const auto [status, out] = testing::run_cli(
        kBinary, "study create --protocol " + std::string(HAPTICLAB_SOURCE_DIR) +
                     "/examples/protocols/thesis_quick.json --db " + db_);
    ASSERT_EQ(status, 0) << out;
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
  std::string db_;
};

// Issue 34 section 3: a practice trial cut short (here by the time limit;
// the watchdog or a device fault end one the same way) was recorded as a
// training trial done. It is counted apart, with why it ended.
TEST_F(SessionCommandTest, APracticeTrialCutShortIsRecordedAsWhatItWas) {
  const fs::path protocol = dir_ / "training.json";
  std::ofstream(protocol) << R"({"study": "training", "tasks": ["clip"], "repetitions": {"clip": 1},
    "settings": [{"name": "High Fidelity"}, {"name": "Copy"}], "participants": ["A"], "training_trials": 2,
    "design": {"type": "complete"}, "seed": 5})";
  const std::string db = (dir_ / "training.db").string();
  auto [status, out] = testing::run_cli(kBinary, "study create --protocol " + protocol.string() + " --db " + db);
  ASSERT_EQ(status, 0) << out;
  // 1 s, the shortest limit session run takes: no practice trial completes the clip task.
  std::tie(status, out) =
      testing::run_cli(kBinary, "session run --db " + db + " --participant A --max-trial-s 1 --max-trials 1");
  ASSERT_EQ(status, 0) << out;
  EXPECT_THAT(out, HasSubstr("after 2 training trials (2 cut short before the task was complete)"));
  // Given time, both are done in full.
  std::tie(status, out) = testing::run_cli(kBinary, "session run --db " + db + " --participant A --max-trials 1");
  ASSERT_EQ(status, 0) << out;
  EXPECT_THAT(out, AllOf(HasSubstr("after 2 training trials"), Not(HasSubstr("cut short"))));
  db::StudyDb study(db);
  const std::vector<db::TrainingRow> cut = study.training(1);
  ASSERT_EQ(cut.size(), 1u);
  EXPECT_EQ(cut[0].trials, 0);
  EXPECT_EQ(cut[0].cut_short, 2);
  EXPECT_THAT(cut[0].cut_short_reason, HasSubstr("time limit (1 s) reached before the task was complete"));
  const std::vector<db::TrainingRow> full = study.training(2);
  ASSERT_EQ(full.size(), 1u);
  EXPECT_EQ(full[0].trials, 2);
  EXPECT_EQ(full[0].cut_short, 0);
  EXPECT_EQ(full[0].cut_short_reason, "");
}

// A participant with nothing left to run (the design complete, or
// --max-trials 0) is told so, and the study gets no empty session row each
// time the command is run again.
TEST_F(SessionCommandTest, NothingLeftToRunIsSaidAndAddsNoSession) {
  const fs::path protocol = dir_ / "two.json";
  std::ofstream(protocol) << R"({"study": "two", "tasks": ["clip"], "repetitions": {"clip": 1},
    "settings": [{"name": "High Fidelity"}, {"name": "Copy"}], "participants": ["A", "B"], "training_trials": 0,
    "design": {"type": "complete"}, "seed": 5})";
  const std::string db = (dir_ / "two.db").string();
  auto [status, out] = testing::run_cli(kBinary, "study create --protocol " + protocol.string() + " --db " + db);
  ASSERT_EQ(status, 0) << out;
  const std::string run = "session run --db " + db + " --rate-hz 250 --participant ";
  // B: nothing asked for, nothing run; its 2 trials stay planned.
  std::tie(status, out) = testing::run_cli(kBinary, run + "B --max-trials 0");
  ASSERT_EQ(status, 0) << out;
  EXPECT_THAT(out, HasSubstr("participant B: no trial run, as at most 0 were asked for (0 complete, 0 aborted, 2 "
                             "still planned); no session was added"));
  // A: both trials in one session, then nothing is left.
  std::tie(status, out) = testing::run_cli(kBinary, run + "A");
  ASSERT_EQ(status, 0) << out;
  EXPECT_THAT(out, HasSubstr("session 1 of A: 2 trials run"));
  for (int again = 0; again < 2; ++again) {
    std::tie(status, out) = testing::run_cli(kBinary, run + "A");
    ASSERT_EQ(status, 0) << out;
    EXPECT_THAT(out, HasSubstr("participant A has no trials left to run: 2 complete, 0 aborted"));
    EXPECT_THAT(out, Not(HasSubstr("session 2")));
  }
  db::StudyDb study(db);
  EXPECT_EQ(study.sessions().size(), 1u);
}

TEST_F(SessionCommandTest, ShowPrintsTheScheduleAndProgressSummaryOnlyProgress) {
  const auto [status, out] = testing::run_cli(kBinary, "study show --db " + db_);
  ASSERT_EQ(status, 0) << out;
  // Progress per participant (20 + 20 + 10 trials), then every trial.
  EXPECT_THAT(out, HasSubstr("S3                  10        0"));
  EXPECT_THAT(out, HasSubstr("High Fidelity"));
  EXPECT_THAT(out, HasSubstr("planned"));

  const auto [status2, summary] = testing::run_cli(kBinary, "study show --summary --db " + db_);
  ASSERT_EQ(status2, 0) << summary;
  EXPECT_THAT(summary, HasSubstr("S3                  10        0"));
  EXPECT_THAT(summary, Not(HasSubstr("planned")));
  EXPECT_LT(summary.size(), out.size() / 5);
}

TEST_F(SessionCommandTest, TheStudyRecordsTheVersionAndCommitOfTheBuildThatCreatedIt) {
  const auto [status, version] = testing::run_cli(kBinary, "--version");
  ASSERT_EQ(status, 0) << version;
  // "hapticlab 0.1.0 (commit 0123456789ab)", -dirty with the changes' digest
  // or "unknown" as the tree is.
  EXPECT_THAT(version, ::testing::MatchesRegex("hapticlab [0-9]+\\.[0-9]+\\.[0-9]+ \\(commit [0-9a-f]{12}(-dirty-[0-9a-f]{12})?\\)\n|"
                                               "hapticlab [0-9.]+ \\(commit unknown\\)\n"));
  db::StudyDb db(db_);
  ASSERT_EQ(db.studies().size(), 1u);
  EXPECT_EQ(db.studies().front().software_version + "\n", version);
}

TEST_F(SessionCommandTest, JsonSummariesAreTheOnlyThingOnStdout) {
  const auto [status, out] = testing::run_cli_stdout(
      kBinary, "session run --db " + db_ + " --participant S1 --training-trials 0 --max-trials 1 --json");
  ASSERT_EQ(status, 0) << out;
  const nlohmann::json j = nlohmann::json::parse(out);  // throws (fails the test) on anything but JSON
  EXPECT_EQ(j.at("participant"), "S1");
  EXPECT_EQ(j.at("device"), "sim");
  EXPECT_EQ(j.at("trials_run"), 1);
  EXPECT_EQ(j.at("trials_complete"), 1);
  EXPECT_EQ(j.at("trials_left"), 19);
  EXPECT_TRUE(j.at("device_fault").is_null());
  EXPECT_GT(j.at("updates_logged").get<int>(), 1000);

  const auto [status2, summary] = testing::run_cli_stdout(kBinary, "study show --summary --json --db " + db_);
  ASSERT_EQ(status2, 0) << summary;
  const nlohmann::json progress = nlohmann::json::parse(summary);
  EXPECT_TRUE(progress.is_object()) << summary;

  const auto [status3, checked] = testing::run_cli_stdout(
      kBinary, "settings check --json " + std::string(HAPTICLAB_SOURCE_DIR) + "/examples/settings/friction.json " +
                   db_);  // the database is no settings file
  EXPECT_EQ(status3, 1);
  const nlohmann::json files = nlohmann::json::parse(checked);
  ASSERT_EQ(files.size(), 2u);
  EXPECT_TRUE(files[0].at("ok").get<bool>());
  EXPECT_EQ(files[0].at("settings").at("name"), "Friction");
  EXPECT_FALSE(files[1].at("ok").get<bool>());
  EXPECT_THAT(files[1].at("error").get<std::string>(), HasSubstr("study.db"));
}

TEST_F(SessionCommandTest, RealtimeSaysWhatTheLoopGotAndTheSessionRuns) {
  const auto [status, out] = testing::run_cli(
      kBinary, "session run --db " + db_ + " --participant S1 --training-trials 0 --max-trials 1 --realtime");
  ASSERT_EQ(status, 0) << out;
  // Granted or refused depends on who runs the test; either way it is said.
  EXPECT_THAT(out, ::testing::ContainsRegex("real-time: SCHED_FIFO (priority 80|refused)"));
  EXPECT_THAT(out, HasSubstr("1 complete"));
}

TEST_F(SessionCommandTest, BlindSessionNeverNamesTheSettingTheOperatorViewDoes) {
  const auto [status, blind] = testing::run_cli(
      kBinary, "session run --db " + db_ + " --participant S1 --training-trials 0 --max-trials 2 --blind");
  ASSERT_EQ(status, 0) << blind;
  EXPECT_THAT(blind, HasSubstr("S1 trial 1/20"));
  EXPECT_THAT(blind, HasSubstr("S1 trial 2/20"));
  for (const char* name : kSettingNames) EXPECT_THAT(blind, Not(HasSubstr(name))) << name;

  // The operator view names the setting of the trial (S1's third is in the
  // seeded schedule; any of the names will do).
  const auto [status2, operator_view] = testing::run_cli(
      kBinary, "session run --db " + db_ + " --participant S1 --training-trials 0 --max-trials 1");
  ASSERT_EQ(status2, 0) << operator_view;
  EXPECT_THAT(operator_view, HasSubstr("S1 trial 3/20"));
  int named = 0;
  for (const char* name : kSettingNames)
    if (operator_view.find(std::string("[") + name + "]") != std::string::npos) ++named;
  EXPECT_EQ(named, 1) << operator_view;

  // Three trials complete; the rest still planned.
  const auto [status3, summary] = testing::run_cli(kBinary, "study show --summary --db " + db_);
  ASSERT_EQ(status3, 0);
  EXPECT_THAT(summary, HasSubstr("S1                  20        3        0        0       17"));
}

// A setting edited with an SQLite shell between two sessions: the next
// session would have configured its engine with it. `session run` refuses
// before anything is recorded, naming the setting; the text put back, the
// study goes on.
TEST_F(SessionCommandTest, ASessionRefusesAStudyWhoseSettingWasEdited) {
  const std::string run = "session run --db " + db_ + " --participant S1 --training-trials 0 --max-trials 1";
  ASSERT_EQ(testing::run_cli(kBinary, run).first, 0);
  const std::string sql = "SELECT parameters_json FROM setting WHERE name = 'Friction'";
  testing::edit_with_sqlite(db_, "UPDATE setting SET parameters_json = replace(parameters_json, '\"friction\"', "
                                 "'\"friction_off\"') WHERE name = 'Friction'");
  const auto [status, out] = testing::run_cli(kBinary, run);
  EXPECT_EQ(status, 1) << out;
  EXPECT_THAT(out, HasSubstr(db_ + ": the file's structure is damaged, 1 finding(s); setting 'Friction' (id "));
  EXPECT_THAT(out, HasSubstr("its parameters_json does not match the SHA-256 stored with it"));
  testing::edit_with_sqlite(db_, "UPDATE setting SET parameters_json = replace(parameters_json, '\"friction_off\"', "
                                 "'\"friction\"') WHERE name = 'Friction'");
  const auto [status2, out2] = testing::run_cli(kBinary, run);
  EXPECT_EQ(status2, 0) << out2;
  const auto [status3, summary] = testing::run_cli(kBinary, "study show --summary --db " + db_);
  ASSERT_EQ(status3, 0) << summary;
  EXPECT_THAT(summary, HasSubstr("S1                  20        2        0        0       18"));
}

double magnitude(const testing::CsvRow& row, const std::string& prefix) {
  double s = 0.0;
  for (const char* axis : {"x", "y", "z"}) {
    const double v = std::stod(row.at(prefix + axis + "_N"));
    s += v * v;
  }
  return std::sqrt(s);
}

// The samples `export` writes for one trial of `db` (into dir/export), as
// rows; empty when the export failed or wrote none.
std::vector<testing::CsvRow> exported_samples(const std::string& db, std::int64_t trial, const fs::path& dir) {
  const auto [status, out] = testing::run_cli(
      kBinary, "export --db " + db + " --trial " + std::to_string(trial) + " --format csv --out " +
                   (dir / "export").string());
  EXPECT_EQ(status, 0) << out;
  if (status != 0) return {};
  for (const auto& e : fs::directory_iterator(dir / "export"))
    if (e.path().string().ends_with("_samples.csv")) return testing::read_csv_rows(e.path());
  return {};
}

// A trial a session logged, replayed through its own setting and task
// layout, gives back the VE forces it recorded: the database holds the raw
// positions as float32 (at most 6 nm on a 0.1 m insertion), which against
// tissue of at most a few kN/m is a few µN; 1e-4 N leaves room for the
// contact dynamics. Replayed through No Force Feedback, the same motion
// meets the same tissue but the device displays nothing.
TEST_F(SessionCommandTest, ALoggedTrialReplaysWithItsRecordedForces) {
  // Recorded and replayed at 250 Hz: a replay must give the recorded forces
  // at any rate, and the trial's rows (both CSVs read here) are this test's
  // time. The first replay names no rate: it takes the recording's.
  const auto [status, out] = testing::run_cli(
      kBinary, "session run --db " + db_ + " --participant S1 --training-trials 0 --max-trials 1 --rate-hz 250");
  ASSERT_EQ(status, 0) << out;
  std::int64_t trial = 0;
  {
    db::OpenOptions open;
    open.read_only = true;
    db::StudyDb db(db_, open);
    for (const auto& t : db.trials())
      if (t.status == db::TrialStatus::kComplete) trial = t.id;
  }
  ASSERT_GT(trial, 0);

  const fs::path replay_csv = dir_ / "replay.csv";
  const auto [status2, summary] = testing::run_cli(
      kBinary, "sim replay --db " + db_ + " --trial " + std::to_string(trial) + " --out " + replay_csv.string());
  ASSERT_EQ(status2, 0) << summary;
  EXPECT_THAT(summary, HasSubstr("at 250 Hz, the recording's rate"));
  EXPECT_THAT(summary, HasSubstr("end_of_data"));
  EXPECT_THAT(summary, HasSubstr("task complete"));

  // One layout: a row per instrument and update, in the same order.
  const auto recorded = exported_samples(db_, trial, dir_);
  ASSERT_FALSE(recorded.empty());
  const auto replayed = testing::read_csv_rows(replay_csv);
  ASSERT_EQ(recorded.size(), replayed.size());
  double worst_N = 0.0, peak_N = 0.0;
  for (std::size_t k = 0; k < recorded.size(); ++k) {
    const auto& r = recorded[k];
    ASSERT_EQ(r.at("tick"), replayed[k].at("tick"));
    ASSERT_EQ(r.at("instrument"), replayed[k].at("instrument"));
    const double f_N = magnitude(r, "ve_force_");
    worst_N = std::max(worst_N, std::abs(f_N - magnitude(replayed[k], "ve_force_")));
    peak_N = std::max(peak_N, f_N);
  }
  EXPECT_GT(peak_N, 0.1);  // the trial touched tissue
  EXPECT_LT(worst_N, 1e-4);

  const fs::path no_ffb_csv = dir_ / "no_ffb.csv";
  const auto [status4, summary4] = testing::run_cli(
      kBinary, "sim replay --db " + db_ + " --trial " + std::to_string(trial) + " --rate-hz 250 --settings " +
                   std::string(HAPTICLAB_SOURCE_DIR) + "/examples/settings/no_force_feedback.json --out " +
                   no_ffb_csv.string());
  ASSERT_EQ(status4, 0) << summary4;
  EXPECT_THAT(summary4, HasSubstr("through No Force Feedback"));
  double ve_peak_N = 0.0, displayed_peak_N = 0.0;
  for (const auto& row : testing::read_csv_rows(no_ffb_csv)) {
    ve_peak_N = std::max(ve_peak_N, magnitude(row, "ve_force_"));
    displayed_peak_N = std::max(displayed_peak_N, magnitude(row, "displayed_force_"));
  }
  EXPECT_GT(ve_peak_N, 0.1);
  EXPECT_EQ(displayed_peak_N, 0.0);
}

// A trial of a study whose protocol lowers the force limits was driven with
// the limited commands, and its replay is too: the commanded insertion
// force and pitch/yaw torques it logged come back (to the float32 the
// database stores, see the tolerances below), the limits reached in
// places. Without the study's limits the replay commanded more than the
// session did.
TEST_F(SessionCommandTest, AReplayIsDrivenUnderItsStudysForceLimits) {
  const fs::path protocol = dir_ / "limited.json";
  std::ofstream(protocol) << R"({"study": "limited", "tasks": ["dissection"], "repetitions": {"dissection": 1},
    "settings": [{"name": "High Fidelity"}, {"name": "Copy"}], "participants": ["A"], "training_trials": 0,
    "design": {"type": "complete"}, "seed": 5,
    "safety": {"max_insertion_force_N": 0.05, "max_pitch_yaw_torque_Nm": 0.002}})";
  const std::string db = (dir_ / "limited.db").string();
  auto [status, out] = testing::run_cli(kBinary, "study create --protocol " + protocol.string() + " --db " + db);
  ASSERT_EQ(status, 0) << out;
  std::tie(status, out) =
      testing::run_cli(kBinary, "session run --db " + db + " --participant A --max-trials 1 --rate-hz 250");
  ASSERT_EQ(status, 0) << out;
  const fs::path replay_csv = dir_ / "replay.csv";
  std::tie(status, out) = testing::run_cli(kBinary, "sim replay --db " + db + " --trial 1 --out " + replay_csv.string());
  ASSERT_EQ(status, 0) << out;
  const auto recorded = exported_samples(db, 1, dir_);
  ASSERT_FALSE(recorded.empty());
  const auto replayed = testing::read_csv_rows(replay_csv);
  ASSERT_EQ(recorded.size(), replayed.size());
  int at_limit = 0;
  std::array<double, 3> worst{};
  const char* columns[] = {"insertion_force_N", "pitch_torque_Nm", "yaw_torque_Nm"};
  for (std::size_t k = 0; k < recorded.size(); ++k) {
    for (std::size_t c = 0; c < 3; ++c) {
      worst[c] = std::max(worst[c], std::abs(std::stod(replayed[k].at(columns[c])) - std::stod(recorded[k].at(columns[c]))));
    }
    if (std::abs(std::stod(recorded[k].at("insertion_force_N"))) >= 0.05 * (1 - 1e-6)) ++at_limit;
  }
  std::printf("  worst differences: insertion %.3g N, pitch %.3g N·m, yaw %.3g N·m; %d rows at the insertion limit\n",
              worst[0], worst[1], worst[2], at_limit);
  EXPECT_GT(at_limit, 0) << "the insertion limit was never reached: the test shows nothing";
  // As ALoggedTrialReplaysWithItsRecordedForces: the positions come back as
  // float32 (measured here: 3e-6 N, 2e-8 and 9e-8 N·m; without the
  // study's limits 1.4 N and 0.07 N·m).
  EXPECT_LT(worst[0], 1e-4);
  EXPECT_LT(worst[1], 1e-5);
  EXPECT_LT(worst[2], 1e-5);
}

TEST_F(SessionCommandTest, ReplayNamesWhatIsMissing) {
  const auto [status, out] =
      testing::run_cli(kBinary, "sim replay --db " + db_ + " --trial 1 --out " + (dir_ / "x.csv").string());
  EXPECT_NE(status, 0);
  EXPECT_THAT(out, HasSubstr("no stored samples"));
  const auto [status2, out2] = testing::run_cli(kBinary, "sim replay --db " + db_ + " --out x.csv");
  EXPECT_NE(status2, 0);
  EXPECT_THAT(out2, HasSubstr("--trial"));
  EXPECT_FALSE(fs::exists(dir_ / "x.csv"));
}

}  // namespace
}  // namespace hapticlab
