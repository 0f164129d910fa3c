// Device faults a whole session must name (issue 33 §1), through the real
// binary and the fake device plugin loaded in-process (plugin-inprocess:;
// an isolated one is tested in device_plugin_session_test.cc):
// - a device whose write() takes 5 ms runs a 1 kHz study at 200 Hz: the
//   trial ends as rate_violation with the measured rate, re-queued, exit 3,
//   where it used to run the whole trial at that rate and exit 0; within
//   the protocol's rate_tolerance_fraction the same device runs on;
// - a plugin that crashes in read() kills the session (it shares the
//   process), but the cause is in the lock file and the next session's
//   recovery records "device_crashed: SIGSEGV in read", not "crashed or
//   killed"; the device was halted on the way down;
// - a read() that hangs is announced at once, and recorded as "device read
//   hung for N ms", whether it comes back, never does, or the operator
//   kills the session meanwhile.
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/cli_process.h"
#include "db/session_lock.h"
#include "db/study_db.h"
#include "testing/child_process.h"
#include "testing/scratch_dir.h"
#include "tests/testing/test_paths.h"

namespace hapticlab {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::StartsWith;

class DeviceFaultSessionTest : public ::testing::Test {
 protected:
  // One participant, two settings, one repetition of the dissection: two
  // planned trials. `extra`: more top-level protocol fields.
  std::string create_study(const std::string& extra = "", const std::string& name = "study.db") {
    const fs::path protocol = dir_.path() / "protocol.json";
    const std::string settings = std::string(HAPTICLAB_SOURCE_DIR) + "/examples/settings/";
    std::ofstream(protocol) << R"({"study": "device faults", "tasks": ["dissection"], "repetitions": {"dissection": 1},
      "settings": [")" << settings << R"(high_fidelity.json", ")" << settings << R"(no_force_feedback.json"],
      "participants": ["P1"], "design": {"type": "complete"}, "seed": 5)"
                            << extra << "}";
    const std::string db = (dir_.path() / name).string();
    const auto [status, out] = testing::run_cli(kBinary, "study create --protocol " + protocol.string() + " --db " + db);
    EXPECT_EQ(status, 0) << out;
    return db;
  }
  // Wall-clock sessions are given up to three trials: on a loaded CI
  // machine the lateness watchdog may end one before its fault shows (the
  // session re-queues it and goes on, as it does for a lab), and the test
  // looks at the trial the fault ended.
  std::string session(const std::string& db, const std::string& args, int max_trials = 3) const {
    return "session run --db " + db + " --participant P1 --training-trials 0 --max-trials " +
           std::to_string(max_trials) + " --device plugin-inprocess:" + kFake + " " + args;
  }
  static std::vector<db::TrialRow> trials_of(const std::string& db) {
    db::OpenOptions open;
    open.read_only = true;
    return db::StudyDb(db, open).trials();
  }
  // The first aborted trial, leaving out those a host watchdog trip ended.
  static const db::TrialRow* aborted(const std::vector<db::TrialRow>& trials) {
    for (const db::TrialRow& t : trials)
      if (t.status == db::TrialStatus::kAborted && !t.abort_reason.starts_with("watchdog: ")) return &t;
    return nullptr;
  }
  // The aborted trial's slot has a planned copy: it runs again later.
  static bool requeued(const std::vector<db::TrialRow>& trials, const db::TrialRow& t) {
    for (const db::TrialRow& u : trials)
      if (u.id != t.id && u.status == db::TrialStatus::kPlanned && u.position == t.position) return true;
    return false;
  }
  std::string report() const {
    std::ifstream in(dir_.path() / "report.txt");
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }

  testing::ScratchDir dir_;
};

TEST_F(DeviceFaultSessionTest, ADeviceTooSlowForTheRateEndsTheTrialAsRateViolationAndIsRequeued) {
  // On a loaded CI machine a 5 ms sleep in write() can overrun 20 ms, which
  // ends the session as a write that hung (rightly): then it runs again, at
  // most three times.
  std::string db, out;
  int status = 0;
  for (int attempt = 0; attempt < 3; ++attempt) {
    db = create_study("", "study" + std::to_string(attempt) + ".db");
    std::tie(status, out) =
        testing::run_cli(kBinary, session(db, "--clock wall --max-trial-s 4 --device-option fault=slow_write"));
    if (out.find("hung for") == std::string::npos) break;
  }
  EXPECT_EQ(status, 3) << out;
  EXPECT_THAT(out, HasSubstr("rate_violation"));
  const std::vector<db::TrialRow> trials = trials_of(db);
  const db::TrialRow* t = aborted(trials);
  ASSERT_NE(t, nullptr) << out;
  // 5 ms per update: about 200 Hz measured over the first 1 s window.
  EXPECT_THAT(t->abort_reason, StartsWith("rate_violation: the loop ran at "));
  EXPECT_THAT(t->abort_reason, HasSubstr("where the schedule asked for 1000.0 Hz"));
  EXPECT_THAT(t->abort_reason, HasSubstr("tolerance 10.0 %"));
  const double achieved_Hz = std::stod(t->abort_reason.substr(std::string("rate_violation: the loop ran at ").size()));
  EXPECT_GT(achieved_Hz, 100.0);
  EXPECT_LT(achieved_Hz, 215.0);
  EXPECT_TRUE(requeued(trials, *t));
  // Its samples up to the end are kept.
  db::OpenOptions open;
  open.read_only = true;
  EXPECT_GT(db::StudyDb(db, open).sample_count(t->id, 0), 100u);
}

TEST_F(DeviceFaultSessionTest, TheProtocolsRateToleranceDecidesWhatIsAViolation) {
  // 1.5 ms per write: about 650 Hz of 1000, 35 % slow; the protocol allows 50 %.
  std::string db, out;
  int status = 0;
  for (int attempt = 0; attempt < 3; ++attempt) {  // as above: a write that overran 20 ms on a loaded machine
    db = create_study(R"(, "rate_tolerance_fraction": 0.5)", "study" + std::to_string(attempt) + ".db");
    std::tie(status, out) = testing::run_cli(
        kBinary, session(db, "--clock wall --max-trial-s 1.3 --device-option fault=slow_write "
                             "--device-option write_delay_us=1500", 1));
    if (out.find("hung for") == std::string::npos) break;
  }
  EXPECT_EQ(status, 0) << out;
  EXPECT_THAT(out, Not(HasSubstr("rate_violation"))) << out;
  const std::vector<db::TrialRow> trials = trials_of(db);
  const db::TrialRow* t = aborted(trials);
  // A host watchdog trip may have ended the one trial instead (re-queued).
  if (t != nullptr) {
    EXPECT_THAT(t->abort_reason, StartsWith("time limit")) << out;
  }
}

TEST_F(DeviceFaultSessionTest, AnInProcessPluginThatCrashesInReadIsRecordedAsSuchByTheNextSession) {
  const std::string db = create_study();
  const std::string report_path = (dir_.path() / "report.txt").string();
  const auto [status, out] = testing::run_cli(
      kBinary, session(db, "--clock virtual --device-option fault=crash_in_read --device-option after=300 "
                           "--device-option report=" + report_path));
  // The shell reports death by SIGSEGV as 128 + 11.
  EXPECT_EQ(status, 139) << out;
  // On the way down the device was halted (zero force).
  EXPECT_THAT(report(), HasSubstr("halts 1"));
  std::ifstream lock(db::SessionLock::lock_path(db, 1));
  std::stringstream note;
  note << lock.rdbuf();
  EXPECT_THAT(note.str(), HasSubstr("abort_reason=device_crashed: SIGSEGV in read\n"));

  // The next session recovers the trial with the cause and re-queues it
  // (--max-trials 0: it stops there, so the copy stays planned).
  const auto [again, out2] = testing::run_cli(kBinary, session(db, "--clock virtual", 0));
  EXPECT_EQ(again, 0) << out2;
  EXPECT_THAT(out2, HasSubstr("device_crashed: SIGSEGV in read"));
  const std::vector<db::TrialRow> trials = trials_of(db);
  const db::TrialRow* t = aborted(trials);
  ASSERT_NE(t, nullptr) << out2;
  EXPECT_EQ(t->abort_reason, "device_crashed: SIGSEGV in read");
  EXPECT_TRUE(requeued(trials, *t));
}

// The session process crashes (SIGSEGV, not in the device) while an
// isolated plugin drives the device: its crash handler halts the device and
// waits for the host to have done it, since the host dies with the process
// (PR_SET_PDEATHSIG). Before, the handler only asked, and the host was
// killed before its halt reached the plugin (5 of 5 times in a review).
TEST_F(DeviceFaultSessionTest, ASessionThatCrashesHaltsAnIsolatedPluginBeforeItsHostDies) {
  const std::string db = create_study();
  const std::string report_path = (dir_.path() / "report.txt").string();
  std::string args = session(db, "--clock wall --max-trial-s 20 --device-option report=" + report_path, 1);
  args.replace(args.find("plugin-inprocess:"), std::string("plugin-inprocess:").size(), "plugin-isolated:");
  std::vector<std::string> argv = {kBinary};
  std::istringstream words(args);
  for (std::string w; words >> w;) argv.push_back(w);
  testing::ChildProcess child(argv, (dir_.path() / "crashed.log").string());
  // Until its trial runs (the loop is driving the device).
  ASSERT_TRUE(testing::wait_until(
      [&] {
        for (const db::TrialRow& t : trials_of(db))
          if (t.status == db::TrialStatus::kRunning) return true;
        return false;
      },
      std::chrono::seconds(30)))
      << child.output();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  child.kill(SIGSEGV);
  child.wait();
  EXPECT_THAT(report(), HasSubstr("halts 1")) << child.output();
}

TEST_F(DeviceFaultSessionTest, AReadThatHangsAndComesBackEndsTheTrialAsHung) {
  const std::string db = create_study();
  const auto [status, out] = testing::run_cli(
      kBinary, session(db, "--clock wall --max-trial-s 3 --device-option fault=hang_in_read --device-option "
                           "after=100 --device-option hang_ms=300"));
  EXPECT_EQ(status, 3) << out;
  // Said while it hung, before that trial's end.
  EXPECT_THAT(out, HasSubstr("device read() has not returned for 20 ms"));
  EXPECT_LT(out.find("has not returned"), out.find("(device read hung for")) << out;
  const std::vector<db::TrialRow> trials = trials_of(db);
  const db::TrialRow* t = aborted(trials);
  ASSERT_NE(t, nullptr) << out;
  EXPECT_THAT(t->abort_reason, StartsWith("device read hung for "));
  const int hung_ms = std::stoi(t->abort_reason.substr(std::string("device read hung for ").size()));
  EXPECT_GE(hung_ms, 300);
  EXPECT_LT(hung_ms, 1000);
}

TEST_F(DeviceFaultSessionTest, AReadThatNeverReturnsIsAnnouncedAtOnceAndRecordedWhenTheSessionGivesUpOrIsKilled) {
  const std::string db = create_study();
  const std::string args = session(db, "--clock wall --max-trial-s 10 --device-option fault=hang_in_read "
                                       "--device-option after=100");
  // Killed by the operator while hung: the lock file tells the next session why.
  {
    std::vector<std::string> argv = {kBinary};
    std::istringstream words(args);
    for (std::string w; words >> w;) argv.push_back(w);
    testing::ChildProcess child(argv, (dir_.path() / "killed.log").string());
    ASSERT_TRUE(testing::wait_until(
        [&] { return child.output().find("device read() has not returned") != std::string::npos; },
        std::chrono::seconds(20)))
        << child.output();
    child.kill(SIGKILL);
    child.wait();
  }
  // The next session recovers it (and hangs again: given up after the grace period).
  const auto start = std::chrono::steady_clock::now();
  const auto [status, out] = testing::run_cli(kBinary, args);
  const double took_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(status, 3) << out;
  EXPECT_THAT(out, HasSubstr("had not returned when the session gave up on it"));
  EXPECT_LT(took_s, 15.0) << out;
  std::vector<std::string> reasons;
  const std::vector<db::TrialRow> trials = trials_of(db);
  for (const db::TrialRow& t : trials) {
    if (t.status != db::TrialStatus::kAborted || t.abort_reason.starts_with("watchdog: ")) continue;
    reasons.push_back(t.abort_reason);
    EXPECT_TRUE(requeued(trials, t)) << t.id;
  }
  ASSERT_EQ(reasons.size(), 2u);
  EXPECT_EQ(reasons[0], "device read hung for at least 20 ms (the session ended before it returned)");
  EXPECT_THAT(reasons[1], StartsWith("device read hung for "));
  EXPECT_THAT(reasons[1], HasSubstr(" ms and had not returned when the session gave up on it"));
}

// The loop's last calls as a trial ends: a deactivate() that fails is a
// device fault (the device may still be powered: exit 3, named, and an
// event of the trial), not a normal end with exit 0.
TEST_F(DeviceFaultSessionTest, ADeactivateThatFailsEndsTheSessionAsADeviceFault) {
  const std::string db = create_study();
  const auto [status, out] =
      testing::run_cli(kBinary, session(db, "--clock virtual --max-trial-s 1 --device-option fault=fail_deactivate", 1));
  EXPECT_EQ(status, 3) << out;
  EXPECT_THAT(out, HasSubstr("device deactivate() failed (write_failed) as trial "));
  EXPECT_THAT(out, HasSubstr("the device may still be powered"));
  db::OpenOptions open;
  open.read_only = true;
  db::StudyDb study(db, open);
  bool recorded = false;
  for (const db::TrialRow& t : study.trials())
    for (const db::EventRow& e : study.events(t.id)) recorded = recorded || e.type == "device_shutdown_fault";
  EXPECT_TRUE(recorded) << "the trial's record does not say it";
}

// ... and one that never returns: the watchdog halts the device after
// kShutdownCallLimit_s, the operator is told at once, and the session gives
// up on it after the grace period (exit 3), as on a read that never returns;
// before, the session waited for it for good, Ctrl-C included.
TEST_F(DeviceFaultSessionTest, ADeactivateThatNeverReturnsIsAnnouncedAndGivenUpOn) {
  const std::string db = create_study();
  const auto start = std::chrono::steady_clock::now();
  const auto [status, out] = testing::run_cli(
      kBinary, session(db, "--clock wall --max-trial-s 1 --device-option fault=hang_in_deactivate", 1));
  const double took_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(status, 3) << out;
  EXPECT_THAT(out, HasSubstr("device deactivate() has not returned for 2500 ms"));
  EXPECT_THAT(out, HasSubstr("had not returned when the session gave up on it"));
  EXPECT_LT(took_s, 15.0) << out;
  const std::vector<db::TrialRow> trials = trials_of(db);
  const db::TrialRow* t = aborted(trials);
  ASSERT_NE(t, nullptr) << out;
  EXPECT_THAT(t->abort_reason, StartsWith("device deactivate hung for "));
  EXPECT_TRUE(requeued(trials, *t));
}

// The same hang in the training before the first trial: said at once, and
// given up on after the grace period as in a trial (before, the practice
// trial waited for the call for good, and the session with it). The trial
// stays planned; the training is recorded as cut short by the hang.
TEST_F(DeviceFaultSessionTest, AReadThatNeverReturnsInTrainingIsGivenUpOnAndTheTrialStaysPlanned) {
  const std::string db = create_study();
  std::string args = session(db, "--clock wall --max-trial-s 10 --device-option fault=hang_in_read "
                                 "--device-option after=100");
  args.replace(args.find("--training-trials 0"), std::string("--training-trials 0").size(), "--training-trials 1");
  const auto start = std::chrono::steady_clock::now();
  const auto [status, out] = testing::run_cli(kBinary, args);
  const double took_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(status, 3) << out;
  EXPECT_THAT(out, HasSubstr("the watchdog halted the device (zero force) in the training before trial "));
  EXPECT_THAT(out, HasSubstr("had not returned when the session gave up on it (in the training before trial "));
  EXPECT_LT(took_s, 15.0) << out;
  for (const db::TrialRow& t : trials_of(db)) EXPECT_EQ(t.status, db::TrialStatus::kPlanned) << t.id;
  db::OpenOptions open;
  open.read_only = true;
  db::StudyDb study(db, open);
  const db::SessionRow row = study.session(1);  // the study's only session
  EXPECT_EQ(row.status, db::SessionStatus::kInterrupted);
  // A device a person holds (the fake plugin has no simulated hand): no
  // participant model with the session, and the loop's rate.
  EXPECT_EQ(row.participant_model, "");
  EXPECT_EQ(row.rate_Hz, 1000.0);
  const auto training = study.training(1);
  ASSERT_EQ(training.size(), 1u);
  EXPECT_EQ(training[0].trials, 0);
  EXPECT_EQ(training[0].cut_short, 1);
  EXPECT_THAT(training[0].cut_short_reason, StartsWith("device read hung for "));
}

}  // namespace
}  // namespace hapticlab

namespace hapticlab {
namespace {

// "plugin:" runs isolated where isolation costs under 20 µs per update: with
// a real-time loop (BENCHMARKS.md). Its crash then ends the trial, named,
// and the session exits 3 instead of dying with the plugin.
TEST_F(DeviceFaultSessionTest, WithARealtimeLoopPluginMeansIsolatedSoACrashEndsOnlyTheTrial) {
  const std::string db = create_study();
  const auto [status, out] = testing::run_cli(
      kBinary, "session run --db " + db + " --participant P1 --training-trials 0 --max-trials 3 --clock wall "
                   "--realtime --max-trial-s 3 --device plugin:" + kFake +
                   " --device-option fault=crash_in_read --device-option after=200");
  if (out.find("SCHED_FIFO refused") != std::string::npos) GTEST_SKIP() << "no real-time scheduling here: " << out;
  EXPECT_EQ(status, 3) << out;
  const std::vector<db::TrialRow> trials = trials_of(db);
  const db::TrialRow* t = aborted(trials);
  ASSERT_NE(t, nullptr) << out;
  EXPECT_EQ(t->abort_reason, "device_crashed: SIGSEGV in read");
  EXPECT_TRUE(requeued(trials, *t));
  db::OpenOptions open;
  open.read_only = true;
  EXPECT_EQ(db::StudyDb(db, open).sample_count(t->id, 0), 200u);  // every update before the crash
}

}  // namespace
}  // namespace hapticlab
