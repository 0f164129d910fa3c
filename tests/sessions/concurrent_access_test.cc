// Concurrent access to one study database, with real processes: sessions
// run by the `hapticlab` binary while other programs read the file (study
// show, analyze, export, the sqlite3 shell), two stations running two
// participants at once, a second session for a participant who already has
// one, and a session killed with SIGKILL whose lock is taken over.
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/cli_process.h"
#include "db/session_lock.h"
#include "db/study_db.h"
#include "testing/child_process.h"
#include "tests/testing/test_paths.h"

namespace hapticlab {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::ChildProcess;
using testing::run_cli;
using testing::wait_until;

// Generous: the sanitizer build runs the simulation ~10x slower.
constexpr std::chrono::seconds kPatience{120};

class ConcurrentAccessTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("hapticlab_concurrent_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    db_ = (dir_ / "study.db").string();
    const auto [status, out] = run_cli(kBinary, "study create --protocol " + std::string(HAPTICLAB_SOURCE_DIR) +
                                                    "/examples/protocols/thesis_quick.json --db " + db_);
    ASSERT_EQ(status, 0) << out;
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::unique_ptr<ChildProcess> start_session(const std::string& participant, int max_trials,
                                              const std::string& log) {
    return std::make_unique<ChildProcess>(
        std::vector<std::string>{kBinary, "session", "run", "--db", db_, "--participant", participant,
                                 "--training-trials", "0", "--max-trials", std::to_string(max_trials)},
        (dir_ / log).string());
  }

  // A read-only look through SQLite, as a monitor would.
  std::vector<db::TrialRow> trials_of(const std::string& participant) {
    db::OpenOptions open;
    open.read_only = true;
    open.integrity = db::OpenOptions::Integrity::kSkip;
    db::StudyDb db(db_, open);
    std::vector<db::TrialRow> out;
    for (db::TrialRow& t : db.trials())
      if (t.participant_code == participant) out.push_back(std::move(t));
    return out;
  }

  bool has_running_trial(const std::string& participant) {
    for (const db::TrialRow& t : trials_of(participant))
      if (t.status == db::TrialStatus::kRunning) return true;
    return false;
  }

  // Every trial of the participant complete or planned, `complete` of them
  // complete, none aborted, and none lost samples.
  void expect_clean(const std::string& participant, int complete) {
    db::OpenOptions open;
    open.read_only = true;
    db::StudyDb db(db_, open);  // full integrity check
    int n = 0;
    for (const db::TrialRow& t : db.trials()) {
      if (t.participant_code != participant) continue;
      EXPECT_NE(t.status, db::TrialStatus::kAborted) << "trial " << t.id << ": " << t.abort_reason;
      EXPECT_NE(t.status, db::TrialStatus::kRunning) << "trial " << t.id;
      if (t.status != db::TrialStatus::kComplete) continue;
      ++n;
      EXPECT_GT(db.sample_count(t.id, 0), 100u) << "trial " << t.id;
      EXPECT_EQ(db.sample_count(t.id, 0), db.sample_count(t.id, 1)) << "trial " << t.id;
      for (const db::EventRow& e : db.events(t.id)) {
        EXPECT_NE(e.type, "samples_missing") << "trial " << t.id;
        EXPECT_NE(e.type, "samples_dropped") << "trial " << t.id;
      }
    }
    EXPECT_EQ(n, complete) << participant;
  }

  fs::path dir_;
  std::string db_;
};

// The reproduction: readers of every kind poll the file while a
// session writes. Before the fix, the first reader's open made the session
// die with "disk I/O error" (the header check's close() dropped SQLite's
// locks, the reader deleted the WAL) and left its trial 'running'.
TEST_F(ConcurrentAccessTest, ReadersPollingTheFileNeverStopASession) {
  auto session = start_session("S1", 6, "session.log");
  int rounds = 0;
  const fs::path analysis = dir_ / "analysis", exported = dir_ / "export";
  while (session->running()) {
    const auto [show, show_out] = run_cli(kBinary, "study show --summary --db " + db_);
    EXPECT_EQ(show, 0) << show_out;
    // The exact command. Without a busy timeout (the shell sets
    // none) it may itself be told "database is locked" while a writer
    // checkpoints; what matters is that it does not harm the session.
    run_cli("sqlite3", db_ + " \"select count(*) from trial\"");
    // A reader that waits, as the README advises, always gets its answer.
    const auto [sql, sql_out] = run_cli("sqlite3", "-cmd '.timeout 5000' " + db_ + " \"select count(*) from trial\"");
    EXPECT_EQ(sql, 0) << sql_out;
    // These may find nothing complete yet; they must not harm the session.
    run_cli(kBinary, "analyze --no-plots --no-ks --quiet --db " + db_ + " --out " + analysis.string());
    run_cli(kBinary, "export --format csv --db " + db_ + " --trial 1 --out " + exported.string());
    ++rounds;
  }
  const int status = session->wait();
  ASSERT_EQ(status, 0) << session->output();
  EXPECT_GE(rounds, 2) << "the readers must overlap the session to test anything";
  expect_clean("S1", 6);
}

// Two stations, two participants, one file: both sessions complete. Each
// writer commits every 50 ms, so their transactions collide constantly;
// losing the race must cost a retry, never a trial.
TEST_F(ConcurrentAccessTest, TwoStationsRunTwoParticipantsOnOneFile) {
  auto s1 = start_session("S1", 6, "s1.log");
  auto s2 = start_session("S2", 6, "s2.log");
  while (s1->running() || s2->running()) {
    const auto [sql, sql_out] =
        run_cli("sqlite3", "-cmd '.timeout 5000' " + db_ + " \"select status, count(*) from trial group by status\"");
    EXPECT_EQ(sql, 0) << sql_out;
  }
  ASSERT_EQ(s1->wait(), 0) << s1->output();
  ASSERT_EQ(s2->wait(), 0) << s2->output();
  expect_clean("S1", 6);
  expect_clean("S2", 6);
}

// A second session for the same participant is refused at start, naming
// the first one's pid, and does not touch the first one's live trial.
TEST_F(ConcurrentAccessTest, SecondSessionForTheSameParticipantIsRefused) {
  auto first = start_session("S1", 6, "first.log");
  ASSERT_TRUE(wait_until([&] { return has_running_trial("S1") || !first->running(); }, kPatience));
  ASSERT_TRUE(first->running()) << first->output();

  const auto [status, out] =
      run_cli(kBinary, "session run --db " + db_ + " --participant S1 --training-trials 0 --max-trials 1");
  EXPECT_EQ(status, 1) << out;
  EXPECT_THAT(out, HasSubstr("participant S1 has a session running"));
  EXPECT_THAT(out, HasSubstr("pid " + std::to_string(first->pid())));

  ASSERT_EQ(first->wait(), 0) << first->output();
  expect_clean("S1", 6);
}

// kill -9 mid-trial: the lock file stays behind, unlocked. The next session
// takes it over and says so, the killed trial is recorded as interrupted
// (samples kept) and runs again in its slot.
TEST_F(ConcurrentAccessTest, KilledSessionsLockIsTakenOverAndItsTrialRequeued) {
  auto victim = start_session("S1", 6, "victim.log");
  std::int64_t killed_trial = 0;
  ASSERT_TRUE(wait_until(
      [&] {
        for (const db::TrialRow& t : trials_of("S1")) {
          if (t.status != db::TrialStatus::kRunning) continue;
          db::OpenOptions open;
          open.read_only = true;
          open.integrity = db::OpenOptions::Integrity::kSkip;
          db::StudyDb db(db_, open);
          if (db.sample_count(t.id, 0) > 0) {
            killed_trial = t.id;
            return true;
          }
        }
        return !victim->running();
      },
      kPatience));
  ASSERT_NE(killed_trial, 0) << victim->output();
  victim->kill(SIGKILL);
  EXPECT_EQ(victim->wait(), -SIGKILL);

  // S1 is the first participant of the protocol.
  EXPECT_TRUE(fs::exists(db::SessionLock::lock_path(db_, 1))) << "a killed holder cannot remove its lock file";

  const auto [status, out] =
      run_cli(kBinary, "session run --db " + db_ + " --participant S1 --training-trials 0 --max-trials 1");
  ASSERT_EQ(status, 0) << out;
  EXPECT_THAT(out, HasSubstr("took over the lock"));
  EXPECT_THAT(out, HasSubstr("pid " + std::to_string(victim->pid())));
  EXPECT_FALSE(fs::exists(db::SessionLock::lock_path(db_, 1))) << "a session that ends releases its lock file";

  db::OpenOptions open;
  open.read_only = true;
  db::StudyDb db(db_, open);
  const db::TrialRow killed = db.trial(killed_trial);
  EXPECT_EQ(killed.status, db::TrialStatus::kAborted);
  EXPECT_EQ(killed.abort_reason, db::kInterruptedReason);
  EXPECT_GT(db.sample_count(killed_trial, 0), 0u) << "the killed trial's samples are kept";
  int reruns = 0;
  for (const db::TrialRow& t : db.trials())
    if (t.id != killed_trial && t.position == killed.position && t.participant_code == "S1") {
      EXPECT_EQ(t.status, db::TrialStatus::kComplete);
      ++reruns;
    }
  EXPECT_EQ(reruns, 1);
}

}  // namespace
}  // namespace hapticlab
