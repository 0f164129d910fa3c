#include "app/study/export_command.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <zlib.h>

#include "db/study_db.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;

class ExportCommandTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(::testing::TempDir()) / (std::string("export_command_test_") + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    db_path_ = dir_ / "study.db";
    // A study with a complete trial (3 updates), a running one (a session
    // is in progress) and a planned one.
    db::StudyDb db(db_path_);
    const std::int64_t study = db.add_study({"Export test", "{}", 9, "test"});
    const std::int64_t p = db.add_participant(study, "S07");
    const std::int64_t s = db.add_setting_json(study, "No FFB", "{}");
    const std::int64_t session = db.begin_session(p, "sim", "wall", 1000.0);
    complete_ = db.add_trial({p, "clip", s, 1, 1, 1});
    running_ = db.add_trial({p, "clip", s, 2, 1, 2});
    planned_ = db.add_trial({p, "clip", s, 3, 2, 3});
    db.start_trial(complete_, session);
    for (int k = 0; k < 2; ++k) {
      std::vector<db::StoredSample> samples(3);
      for (std::size_t i = 0; i < 3; ++i) {
        samples[i].tick = i;
        samples[i].t_s = 0.001 * static_cast<double>(i);
        samples[i].dt_s = 0.001;
        samples[i].value.ve_force_N[2] = 0.5 * static_cast<double>(k + 1);
      }
      db.insert_chunk(complete_, k, samples);
    }
    db.add_event({complete_, 0.001, "clip_applied", 1, 0, ""});
    db.end_trial(complete_, db::TrialStatus::kComplete);
    db.start_trial(running_, session);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // `hapticlab export ...`, in process, through CLI11; returns stdout.
  static std::string run(std::vector<std::string> args) {
    CLI::App app;
    add_export_command(app);
    args.insert(args.begin(), "export");
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

  // The message of the std::exception `args` throws, or "" if none.
  static std::string error_of(const std::vector<std::string>& args) {
    try {
      run(args);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  }

  static std::vector<std::string> lines(const fs::path& path) {
    std::ifstream in(path);
    std::vector<std::string> out;
    for (std::string line; std::getline(in, line);) out.push_back(line);
    return out;
  }

  fs::path dir_, db_path_;
  std::int64_t complete_ = 0, running_ = 0, planned_ = 0;
};

TEST_F(ExportCommandTest, OneTrial) {
  const fs::path out = dir_ / "one";
  const std::string printed =
      run({"--db", db_path_.string(), "--trial", std::to_string(complete_), "--format", "csv", "--out", out.string()});
  EXPECT_THAT(printed, AllOf(HasSubstr("trial " + std::to_string(complete_)), HasSubstr("2 files")));
  const std::string stem = "s07_clip_no_ffb_rep1_trial" + std::to_string(complete_);
  const std::vector<std::string> samples = lines(out / (stem + "_samples.csv"));
  ASSERT_EQ(samples.size(), 1u + 6u);
  EXPECT_THAT(samples[0], HasSubstr("trial_id,participant,task,setting,repetition,instrument,tick,dt_s,t_s,"));
  EXPECT_THAT(samples[1], HasSubstr(std::to_string(complete_) + ",S07,clip,No FFB,1,0,0,0.001,0,"));
  EXPECT_THAT(samples[6], HasSubstr(std::to_string(complete_) + ",S07,clip,No FFB,1,1,2,0.001,0.002,"));
  const std::vector<std::string> events = lines(out / (stem + "_events.csv"));
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[1], std::to_string(complete_) + ",S07,clip,No FFB,1,0.001,clip_applied,1,0,");
}

TEST_F(ExportCommandTest, WholeStudyLeavesARunningTrialAlone) {
  const fs::path out = dir_ / "all";
  run({"--db", db_path_.string(), "--format", "csv", "--out", out.string()});
  const std::vector<std::string> trials = lines(out / "trials.csv");
  ASSERT_EQ(trials.size(), 4u);
  EXPECT_THAT(trials[1], HasSubstr(",complete,"));
  EXPECT_THAT(trials[2], HasSubstr(",running,"));
  EXPECT_THAT(trials[3], HasSubstr(",planned,"));
  EXPECT_TRUE(fs::exists(out / ("s07_clip_no_ffb_rep1_trial" + std::to_string(complete_) + "_samples.csv")));
  EXPECT_TRUE(fs::exists(out / ("s07_clip_no_ffb_rep2_trial" + std::to_string(running_) + "_events.csv")));
  EXPECT_FALSE(fs::exists(out / ("s07_clip_no_ffb_rep3_trial" + std::to_string(planned_) + "_samples.csv")));
  // Export opened the file without recovery: the session's trial still runs.
  db::StudyDb db(db_path_, {db::OpenOptions::Integrity::kSkip, /*recover=*/false});
  EXPECT_EQ(db.trial(running_).status, db::TrialStatus::kRunning);
}

TEST_F(ExportCommandTest, ErrorsNameTheValueAndWhatIsAllowed) {
  const std::string out = (dir_ / "x").string();
  EXPECT_THAT(error_of({"--db", (dir_ / "nope.db").string(), "--format", "csv", "--out", out}),
              AllOf(HasSubstr("--db"), HasSubstr("nope.db"), HasSubstr("does not exist")));
  EXPECT_FALSE(fs::exists(dir_ / "nope.db")) << "a missing database is not created";
  EXPECT_THAT(error_of({"--db", db_path_.string(), "--trial", "77", "--format", "csv", "--out", out}),
              AllOf(HasSubstr("--trial"), HasSubstr("no trial 77"), HasSubstr(db_path_.string()),
                    HasSubstr("trial ids are " + std::to_string(complete_) + ".." + std::to_string(planned_))));
  EXPECT_THAT(error_of({"--db", db_path_.string(), "--format", "json", "--out", out}),
              AllOf(HasSubstr("--format"), HasSubstr("'json'"), HasSubstr("allowed: csv")));
  const fs::path text = dir_ / "notes.txt";
  std::ofstream(text) << "not a database, just notes about the study\n";
  EXPECT_THAT(error_of({"--db", text.string(), "--format", "csv", "--out", out}),
              AllOf(HasSubstr(text.string()), HasSubstr("not an SQLite database")));
  EXPECT_FALSE(fs::exists(out)) << "nothing is written when the command fails";
}

}  // namespace
}  // namespace hapticlab::app

namespace hapticlab::app {
namespace {

// Export options (issue 16): channels, every N-th update, selection, one
// file, gzip. The fixture's complete trial has ticks 0..2 of both hands.
TEST_F(ExportCommandTest, ChannelsEveryAndSelection) {
  const fs::path out = dir_ / "sel";
  run({"--db", db_path_.string(), "--format", "csv", "--out", out.string(), "--channels", "t_s,ve_force_z_N",
       "--every", "2", "--status", "complete", "--one-file"});
  const std::vector<std::string> samples = lines(out / "samples.csv");
  // Ticks 0 and 2 (multiples of 2), left then right: 4 rows.
  ASSERT_EQ(samples.size(), 1u + 4u);
  EXPECT_EQ(samples[0], "trial_id,participant,task,setting,repetition,instrument,tick,t_s,ve_force_z_N");
  const std::string id = std::to_string(complete_);
  EXPECT_EQ(samples[1], id + ",S07,clip,No FFB,1,0,0,0,0.5");
  EXPECT_EQ(samples[2], id + ",S07,clip,No FFB,1,1,0,0,1");
  EXPECT_EQ(samples[3], id + ",S07,clip,No FFB,1,0,2,0.002,0.5");
  // Only the complete trial: trials.csv lists it alone; the running one's event file is not written.
  const std::vector<std::string> trials = lines(out / "trials.csv");
  ASSERT_EQ(trials.size(), 2u);
  EXPECT_THAT(trials[1], HasSubstr(",complete,"));
  EXPECT_EQ(lines(out / "events.csv").size(), 2u);
  EXPECT_EQ(lines(out / "events.csv")[0], "trial_id,participant,task,setting,repetition,t_s,type,instrument,item_index,detail");
}

// The gzip file decompresses to the plain file, byte for byte (zlib here,
// gzip -dc from the shell in the README).
TEST_F(ExportCommandTest, GzipIsThePlainFileCompressed) {
  run({"--db", db_path_.string(), "--format", "csv", "--out", (dir_ / "plain").string(), "--one-file"});
  run({"--db", db_path_.string(), "--format", "csv", "--out", (dir_ / "gz").string(), "--one-file", "--gzip"});
  for (const char* name : {"samples.csv", "events.csv", "trials.csv"}) {
    ASSERT_FALSE(fs::exists(dir_ / "gz" / name));
    gzFile gz = gzopen((dir_ / "gz" / (std::string(name) + ".gz")).c_str(), "rb");
    ASSERT_NE(gz, nullptr) << name;
    std::string text;
    char buffer[4096];
    for (int n; (n = gzread(gz, buffer, sizeof buffer)) > 0;) text.append(buffer, static_cast<std::size_t>(n));
    gzclose(gz);
    std::ifstream plain(dir_ / "plain" / name, std::ios::binary);
    const std::string expected((std::istreambuf_iterator<char>(plain)), std::istreambuf_iterator<char>());
    EXPECT_EQ(text, expected) << name;
    EXPECT_GT(text.size(), 10u);
  }
}

TEST_F(ExportCommandTest, BadSelectionsAreNamed) {
  const std::string out = (dir_ / "bad").string();
  EXPECT_THAT(error_of({"--db", db_path_.string(), "--format", "csv", "--out", out, "--channels", "t_s,force"}),
              AllOf(HasSubstr("'force' is not a channel"), HasSubstr("ve_force_z_N")));
  EXPECT_THAT(error_of({"--db", db_path_.string(), "--format", "csv", "--out", out, "--setting", "Friction"}),
              AllOf(HasSubstr("--setting"), HasSubstr("'Friction' is not in"), HasSubstr("'No FFB'")));
  EXPECT_THAT(error_of({"--db", db_path_.string(), "--format", "csv", "--out", out, "--every", "0"}),
              HasSubstr("--every"));
  // Twice was two columns of one name.
  EXPECT_THAT(error_of({"--db", db_path_.string(), "--format", "csv", "--out", out, "--channels", "t_s,dt_s,t_s"}),
              AllOf(HasSubstr("--channels"), HasSubstr("'t_s' is given twice")));
  // A planned trial was "exported" as two empty files.
  EXPECT_THAT(error_of({"--db", db_path_.string(), "--format", "csv", "--out", out, "--trial",
                        std::to_string(planned_)}),
              HasSubstr("trial " + std::to_string(planned_) + " in " + db_path_.string() +
                        " is planned: it has not run, so it has no samples or events to export"));
  EXPECT_FALSE(fs::exists(out)) << "nothing is written when the command fails";
  EXPECT_THAT(error_of({"--db", db_path_.string(), "--format", "csv", "--out", out, "--trial",
                        std::to_string(complete_), "--participant", "S07"}),
              HasSubstr("--trial"));
}

}  // namespace
}  // namespace hapticlab::app
