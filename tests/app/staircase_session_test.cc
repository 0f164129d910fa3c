// An adaptive staircase through the real binary (issue 19 section 4): the
// baseline trials, then `session run` adds one staircase trial at a time
// until its stopping rule; what it reports is the rule replayed over the
// trials it stored; a session stopped halfway resumes to the same end; and
// a staircase without a baseline is named.
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <thread>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "protocols/protocol_json.h"
#include "protocols/staircase.h"
#include "db/sqlite_handle.h"
#include "tests/app/cli_process.h"
#include "tests/testing/child_process.h"
#include "tests/testing/scratch_dir.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

const fs::path kStaircaseExample = fs::path(HAPTICLAB_SOURCE_DIR) / "examples" / "protocols" / "friction_staircase.json";

class StaircaseSessionTest : public ::testing::Test {
 protected:
  static std::pair<int, std::string> cli(const std::string& args) { return testing::run_cli(HAPTICLAB_CLI_PATH, args); }
  // The example, kept short: one baseline trial, at most 6 staircase trials.
  std::string create(const std::string& name) {
    std::ifstream in(kStaircaseExample);
    nlohmann::json p = nlohmann::json::parse(in);
    p["repetitions"]["clip"] = 1;
    p["staircase"]["reversals"] = 4;
    p["staircase"]["max_trials"] = 6;
    p["settings"] = {(kStaircaseExample.parent_path() / p["settings"][0].get<std::string>()).string()};
    protocol_ = dir_ / "staircase.json";
    std::ofstream(protocol_) << p.dump(2);
    const std::string db = (dir_ / name).string();
    const auto [status, out] = cli("study create --protocol " + protocol_.string() + " --db " + db);
    EXPECT_EQ(status, 0) << out;
    return db;
  }
  static nlohmann::json run_json(const std::string& db, const std::string& extra = "") {
    const auto [status, out] =
        testing::run_cli_stdout(HAPTICLAB_CLI_PATH, "session run --db " + db + " --participant P01 --json " + extra);
    EXPECT_EQ(status, 0) << out;
    return nlohmann::json::parse(out);
  }
  hapticlab::testing::ScratchDir scratch_{"hapticlab_stair_"};
  const fs::path dir_ = scratch_.path();
  fs::path protocol_;
};

TEST_F(StaircaseSessionTest, RunsToItsStoppingRuleAndReportsTheRuleReplayed) {
  const std::string db = create("s.db");
  const nlohmann::json j = run_json(db);
  const nlohmann::json& st = j.at("staircase");
  EXPECT_TRUE(st.at("finished").get<bool>()) << st;
  const std::size_t trials = st.at("trials").get<std::size_t>();
  EXPECT_GE(trials, 1u);
  EXPECT_LE(trials, 6u);  // max_trials
  EXPECT_EQ(j.at("trials_complete").get<std::size_t>(), 1 + trials);  // baseline, then the staircase
  EXPECT_EQ(j.at("trials_left"), 0);

  // The rule replayed over what was stored gives what was reported, and
  // each trial ran at the strength the rule chose after the ones before.
  std::ifstream in(protocol_);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto spec = protocols::staircase_from_protocol_text(text, "example");
  ASSERT_TRUE(spec.has_value());
  std::vector<std::pair<double, double>> steps;
  for (const auto& s : st.at("steps")) {
    const protocols::StaircaseState before = protocols::replay_staircase(*spec, st.at("baseline"), steps);
    EXPECT_FALSE(before.finished);
    EXPECT_EQ(s.at("strength").get<double>(), before.next_strength) << "trial " << steps.size() + 1;
    steps.emplace_back(s.at("strength"), s.at("value"));
  }
  const protocols::StaircaseState end = protocols::replay_staircase(*spec, st.at("baseline"), steps);
  EXPECT_TRUE(end.finished);
  EXPECT_EQ(end.stop_reason, st.at("stop_reason"));
  EXPECT_EQ(nlohmann::json(end.reversal_strengths), st.at("reversals"));
  if (end.threshold) {
    EXPECT_EQ(*end.threshold, st.at("threshold").get<double>());
  } else {
    EXPECT_TRUE(st.at("threshold").is_null());
  }

  // Running the session again adds nothing: the staircase is over.
  const nlohmann::json again = run_json(db);
  EXPECT_EQ(again.at("trials_run"), 0);
  EXPECT_EQ(again.at("staircase"), st);

  // analyze reports the same staircase, its trials apart from the design's.
  const fs::path report = dir_ / "report";
  const auto [status, out] = testing::run_cli_stdout(
      HAPTICLAB_CLI_PATH, "analyze --db " + db + " --out " + report.string() + " --no-ks --json");
  ASSERT_EQ(status, 0) << out;
  const nlohmann::json analysis = nlohmann::json::parse(out);
  EXPECT_EQ(analysis.at("trials").at("staircase").get<std::size_t>(), trials);
  EXPECT_EQ(analysis.at("trials").at("analysed"), 1);  // the baseline trial
  const nlohmann::json& row = analysis.at("staircase").at(0);
  EXPECT_EQ(row.at("participant"), "P01");
  EXPECT_EQ(row.at("threshold"), st.at("threshold"));
  EXPECT_EQ(row.at("reversals"), st.at("reversals"));
  EXPECT_TRUE(fs::exists(report / "figures" / "staircase_P01.svg"));
}

// Stopped after 3 trials (the baseline and two staircase trials), then run
// again: the staircase resumes from the database and ends as one
// uninterrupted session does (same trial rows, same seeds).
TEST_F(StaircaseSessionTest, AStoppedSessionResumesToTheSameEnd) {
  const nlohmann::json whole = run_json(create("whole.db")).at("staircase");
  const std::string db = create("parts.db");
  const nlohmann::json first = run_json(db, "--max-trials 3");
  EXPECT_EQ(first.at("trials_run"), 3);
  EXPECT_FALSE(first.at("staircase").at("finished").get<bool>());
  const nlohmann::json rest = run_json(db);
  EXPECT_EQ(rest.at("staircase"), whole);
}

// Killed in the middle of a trial (the baseline, or a staircase trial),
// then run again: the killed trial is re-queued as a new row, and it runs
// as the killed attempt would have (its slot's seed, not its new id's), as
// do the staircase trials after it (their position's seed): the session
// ends as an uninterrupted one does. Before, a stop in a trial moved every
// later simulated outcome (threshold 0.75 after 11 trials became 0.583
// after 16).
TEST_F(StaircaseSessionTest, AKillInTheMiddleOfATrialResumesToTheSameEnd) {
  const nlohmann::json whole = run_json(create("whole.db")).at("staircase");
  for (const int block : {1, 0}) {
    const std::string db = create("killed_" + std::to_string(block) + ".db");
    testing::ChildProcess session({HAPTICLAB_CLI_PATH, "session", "run", "--db", db, "--participant", "P01"},
                                  (dir_ / ("killed_" + std::to_string(block) + ".log")).string());
    bool killed = false;
    for (int polls = 0; polls < 20000 && session.running() && !killed; ++polls) {
      db::Database conn(db);
      db::Statement q = conn.prepare("SELECT count(*) FROM trial WHERE status = 'running' AND block = ?1");
      q.bind(1, static_cast<std::int64_t>(block));
      if (q.step() && q.column_int64(0) > 0) {
        session.kill(SIGKILL);
        killed = true;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    ASSERT_TRUE(killed) << "no trial of block " << block << " was seen running: " << session.output();
    session.wait();
    EXPECT_EQ(run_json(db).at("staircase"), whole) << "killed in a trial of block " << block;
  }
}

// Every baseline trial hits the time limit (which is not re-queued): there
// is nothing to measure a change from, and the session says so.
TEST_F(StaircaseSessionTest, AStaircaseWithoutABaselineIsNamed) {
  const std::string db = create("none.db");
  const auto [status, out] = cli("session run --db " + db + " --participant P01 --max-trial-s 1");
  EXPECT_EQ(status, 1) << out;
  EXPECT_THAT(out, HasSubstr("staircase.baseline: participant P01 has no complete trial of the baseline "
                             "'High Fidelity' in clip"));
}

}  // namespace
}  // namespace hapticlab::app
