// `session run --device plugin:hapticlab_sim_device.so` through the real
// binary: the same samples as the built-in sim, in-process and isolated; a
// plugin that crashes while loading stops the session before anything is
// stored, and an isolated one that crashes or hangs during a trial ends
// that trial with its reason.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/cli_process.h"
#include "db/study_db.h"
#include "tests/testing/test_paths.h"

namespace hapticlab {
namespace {

namespace fs = std::filesystem;
using ::testing::ContainsRegex;
using ::testing::HasSubstr;
using ::testing::MatchesRegex;
using ::testing::Not;


class DevicePluginSessionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("hapticlab_plugin_session_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A study from the quick thesis protocol (its own fixed study seed).
  std::string create_study(const std::string& name) {
    const std::string db = (dir_ / name).string();
    const auto [status, out] = testing::run_cli(
        kBinary, "study create --protocol " + std::string(HAPTICLAB_SOURCE_DIR) +
                     "/examples/protocols/thesis_quick.json --db " + db);
    EXPECT_EQ(status, 0) << out;
    return db;
  }
  fs::path dir_;
};

db::StudyDb open_read_only(const std::string& path) {
  db::OpenOptions open;
  open.read_only = true;
  return db::StudyDb(path, open);
}

void expect_same(const db::StoredSample& a, const db::StoredSample& b, const std::string& where) {
  ASSERT_EQ(a.tick, b.tick) << where;
  ASSERT_EQ(a.t_s, b.t_s) << where;
  ASSERT_EQ(a.dt_s, b.dt_s) << where;
  ASSERT_EQ(a.device_status, b.device_status) << where;
  ASSERT_EQ(a.value.raw_position, b.value.raw_position) << where;
  ASSERT_EQ(a.value.degraded_position, b.value.degraded_position) << where;
  ASSERT_EQ(a.value.tip_position_m, b.value.tip_position_m) << where;
  ASSERT_EQ(a.value.tip_velocity_m_per_s, b.value.tip_velocity_m_per_s) << where;
  ASSERT_EQ(a.value.ve_force_N, b.value.ve_force_N) << where;
  ASSERT_EQ(a.value.displayed_force_N, b.value.displayed_force_N) << where;
  ASSERT_EQ(a.value.joint_force, b.value.joint_force) << where;
  ASSERT_EQ(a.value.engine_status, b.value.engine_status) << where;
  ASSERT_EQ(a.value.in_contact, b.value.in_contact) << where;
}

// Safety through a whole session (docs/safety.md): a device that is not
// calibrated is never driven and its trial stays planned; a reading that
// jumps 1 m stops the trial with zero force, and the trial is aborted with
// the reason and re-queued, its samples up to then kept.
TEST_F(DevicePluginSessionTest, ANotCalibratedDeviceLeavesTheTrialPlanned) {
  const std::string db = create_study("cal.db");
  const auto [status, out] = testing::run_cli(
      kBinary, "session run --db " + db + " --participant S1 --training-trials 0 --max-trials 1 --device plugin:" +
                   kFake + " --device-option fault=not_calibrated");
  EXPECT_EQ(status, 3) << out;
  EXPECT_THAT(out, HasSubstr("not calibrated/homed; calibrate it, then run the session again"));
  db::StudyDb study = open_read_only(db);
  for (const db::TrialRow& t : study.trials(1)) EXPECT_EQ(t.status, db::TrialStatus::kPlanned) << t.id;
}

// `session run` of participant S1's first trial (at most 5 s) on the fake
// plugin, through `device` ("plugin", "plugin-isolated", ...), with its
// `options` ("fault=jump").
std::pair<int, std::string> run_one_trial_on_fake(const std::string& db, const std::string& options,
                                                  const std::string& device = "plugin") {
  std::string args = "session run --db " + db + " --participant S1 --training-trials 0 --max-trials 1 --max-trial-s 5" +
                     " --device " + device + ":" + kFake;
  for (std::size_t at = 0; at < options.size();) {
    const std::size_t end = std::min(options.find(' ', at), options.size());
    args += " --device-option " + options.substr(at, end - at);
    at = end + 1;
  }
  return testing::run_cli(kBinary, args);
}

TEST_F(DevicePluginSessionTest, AReadingThatJumpsStopsTheTrialWhichIsRequeuedWithItsReason) {
  const std::string db = create_study("jump.db");
  const auto [status, out] = run_one_trial_on_fake(db, "fault=jump");
  EXPECT_EQ(status, 3) << out;
  db::StudyDb study = open_read_only(db);
  int aborted = 0, planned_copies = 0;
  std::int64_t aborted_id = 0;
  const std::vector<db::TrialRow> trials = study.trials(1);
  for (const db::TrialRow& t : trials) {
    if (t.status != db::TrialStatus::kAborted) continue;
    ++aborted;
    aborted_id = t.id;
    EXPECT_THAT(t.abort_reason, ::testing::StartsWith("safety limit: "));
    EXPECT_THAT(t.abort_reason, HasSubstr("insertion"));
    for (const db::TrialRow& u : trials)
      if (u.participant_id == t.participant_id && u.status == db::TrialStatus::kPlanned && u.position == t.position)
        ++planned_copies;
  }
  EXPECT_EQ(aborted, 1);
  EXPECT_EQ(planned_copies, 1);  // re-queued at its place
  // 100 good readings were logged; the jump's update was not.
  EXPECT_EQ(study.samples(aborted_id, 0).size(), 100u);
}

// The abort reasons of participant 1's aborted trials, in id order.
std::vector<std::string> aborted_reasons(const std::string& db) {
  db::StudyDb study = open_read_only(db);
  std::vector<std::string> out;
  for (const db::TrialRow& t : study.trials(1))
    if (t.status == db::TrialStatus::kAborted) out.push_back(t.abort_reason);
  return out;
}

// A live device that answers "end of data" (only a replay may) ends the
// session as a device fault that says so, not as "device fault: ok".
TEST_F(DevicePluginSessionTest, ALiveDeviceThatSaysItsDataRanOutIsAFaultNamedSo) {
  const std::string db = create_study("eod.db");
  const auto [status, out] = run_one_trial_on_fake(db, "fault=end_of_data after=50");
  EXPECT_EQ(status, 3) << out;
  EXPECT_THAT(aborted_reasons(db), ::testing::ElementsAre("device fault: end_of_data: the device said its data "
                                                          "ran out, which only a replay may say"));
}

// A status code the ABI does not define ends the trial as the call's
// failure, and the stored reason names the code and the call, in a
// process of its own and in HapticLab's.
TEST_F(DevicePluginSessionTest, AStatusCodeTheAbiDoesNotDefineIsNamedInTheReason) {
  for (const std::string mode : {"plugin-isolated", "plugin-inprocess"}) {
    const std::string db = create_study(mode + "_unknown_status.db");
    const auto [status, out] = run_one_trial_on_fake(db, "fault=unknown_status after=50", mode);
    EXPECT_EQ(status, 3) << out;
    EXPECT_THAT(aborted_reasons(db), ::testing::ElementsAre("device fault: read_failed: the plugin's read returned "
                                                            "42, which is no hl_device_status (taken as read_failed)"))
        << mode;
  }
}

// The trials of a study that are not planned any more, in id order.
std::vector<db::TrialRow> run_trials(db::StudyDb& study) {
  std::vector<db::TrialRow> trials;
  for (const auto& t : study.trials())
    if (t.status != db::TrialStatus::kPlanned) trials.push_back(t);
  return trials;
}

// Every stored sample of `b` equals that of `a`, bit for bit; returns how
// many were compared.
std::size_t expect_same_trials(db::StudyDb& a, db::StudyDb& b, const std::string& what) {
  const std::vector<db::TrialRow> trials_a = run_trials(a), trials_b = run_trials(b);
  EXPECT_EQ(trials_a.size(), 2u) << what;
  EXPECT_EQ(trials_b.size(), trials_a.size()) << what;
  if (trials_b.size() != trials_a.size()) return 0;
  std::size_t compared = 0;
  for (std::size_t k = 0; k < trials_a.size(); ++k) {
    EXPECT_EQ(trials_a[k].id, trials_b[k].id) << what;
    EXPECT_EQ(trials_a[k].status, trials_b[k].status) << what;
    for (int instrument = 0; instrument < 2; ++instrument) {
      const auto sa = a.samples(trials_a[k].id, instrument), sb = b.samples(trials_b[k].id, instrument);
      EXPECT_EQ(sa.size(), sb.size()) << what << " trial " << trials_a[k].id;
      // Trials of up to 4 s at 1 kHz with a moving participant.
      EXPECT_GT(sa.size(), 500u) << what;
      if (sa.size() != sb.size()) return compared;
      for (std::size_t i = 0; i < sa.size(); ++i) {
        const std::string where = what + " trial " + std::to_string(trials_a[k].id) + " instrument " +
                                  std::to_string(instrument) + " sample " + std::to_string(i);
        expect_same(sa[i], sb[i], where);
        if (::testing::Test::HasFatalFailure()) return compared;
      }
      compared += sa.size();
    }
  }
  return compared;
}

// The sim plugin in-process and isolated (in its host process, the loop
// clock's time crossing with every call) against the built-in sim.
TEST_F(DevicePluginSessionTest, ThePluginSessionLogsTheSameSamplesAsTheBuiltInSim) {
  const std::string sim_db = create_study("sim.db"), plugin_db = create_study("plugin.db"),
                    isolated_db = create_study("isolated.db");
  const std::string run = " --participant S1 --training-trials 0 --max-trials 2 --max-trial-s 4 --clock virtual";
  const auto [s1, out1] = testing::run_cli(kBinary, "session run --db " + sim_db + run + " --device sim");
  ASSERT_EQ(s1, 0) << out1;
  const auto [s2, out2] = testing::run_cli(kBinary, "session run --db " + plugin_db + run +
                                                        " --device plugin-inprocess:" + kSimPlugin +
                                                        " --device-option max_substep_s=1e-3");
  ASSERT_EQ(s2, 0) << out2;
  const auto [s3, out3] = testing::run_cli(kBinary, "session run --db " + isolated_db + run +
                                                        " --device plugin-isolated:" + kSimPlugin +
                                                        " --device-option max_substep_s=1e-3");
  ASSERT_EQ(s3, 0) << out3;

  db::StudyDb a = open_read_only(sim_db), b = open_read_only(plugin_db), c = open_read_only(isolated_db);
  EXPECT_GT(expect_same_trials(a, b, "in-process"), 2000u);
  EXPECT_GT(expect_same_trials(a, c, "isolated"), 2000u);
}

// An isolated plugin that crashes in read() or write() during a trial: the
// session process lives on, the trial is aborted with the signal and the
// call as its reason, its samples up to the crash are kept, it is
// re-queued, the session ends with exit status 3, and the next session
// continues cleanly.
TEST_F(DevicePluginSessionTest, AnIsolatedPluginThatCrashesEndsTheTrialWithItsReasonAndTheNextSessionGoesOn) {
  for (const std::string call : {"read", "write"}) {
    const std::string db = create_study("crash_in_" + call + ".db");
    const std::string run = "session run --db " + db + " --participant S1 --training-trials 0 --max-trials 1 "
                            "--clock virtual --device plugin-isolated:";
    const auto [status, out] =
        testing::run_cli(kBinary, run + kFake + " --device-option fault=crash_in_" + call);
    EXPECT_EQ(status, 3) << out;
    const std::string reason = "device_crashed: SIGSEGV in " + call;
    EXPECT_THAT(out, HasSubstr("hapticlab session run: " + reason + "; the trial is re-queued")) << out;
    {
      db::StudyDb study = open_read_only(db);
      const std::vector<db::TrialRow> trials = study.trials(1);
      int aborted = 0;
      for (const db::TrialRow& t : trials) {
        if (t.status != db::TrialStatus::kAborted) continue;
        ++aborted;
        EXPECT_EQ(t.abort_reason, reason);
        // The fake's first 200 calls of each kind behave (after=200); the
        // update whose call crashed is not stored.
        EXPECT_EQ(study.samples(t.id, 0).size(), 200u) << call;
        EXPECT_EQ(study.samples(t.id, 1).size(), 200u) << call;
        int copies = 0;
        for (const db::TrialRow& u : trials)
          copies += u.participant_id == t.participant_id && u.status == db::TrialStatus::kPlanned &&
                    u.position == t.position;
        EXPECT_EQ(copies, 1) << "re-queued at its place";
      }
      EXPECT_EQ(aborted, 1) << call;
    }
    // The lock was released and the re-queued trial runs next.
    const auto [again, again_out] = testing::run_cli(kBinary, run + kSimPlugin);
    EXPECT_EQ(again, 0) << again_out;
    EXPECT_THAT(again_out, Not(HasSubstr("took over the lock")));
    db::StudyDb study = open_read_only(db);
    int complete = 0;
    for (const db::TrialRow& t : study.trials(1)) complete += t.status == db::TrialStatus::kComplete;
    EXPECT_EQ(complete, 1) << again_out;
  }
}

// A read that never returns: on the virtual clock the host is killed after
// 1 s and the trial records how long the read hung.
TEST_F(DevicePluginSessionTest, AnIsolatedPluginThatHangsInReadIsKilledAndTheTrialSaysHowLong) {
  const std::string db = create_study("hang.db");
  const auto start = std::chrono::steady_clock::now();
  const auto [status, out] = testing::run_cli(
      kBinary, "session run --db " + db + " --participant S1 --training-trials 0 --max-trials 1 --clock virtual " +
                   "--device plugin-isolated:" + kFake + " --device-option fault=hang_in_read");
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 10.0);
  EXPECT_EQ(status, 3) << out;
  // The hang is timed on the wall clock: the 1 s limit plus the host's
  // reaction, which a loaded machine stretches by a few ms (1005 ms seen).
  EXPECT_THAT(out, ContainsRegex("hapticlab session run: device read hung for 1[0-4][0-9][0-9] ms; the trial is "
                                 "re-queued"));
  db::StudyDb study = open_read_only(db);
  int aborted = 0;
  for (const db::TrialRow& t : study.trials(1)) {
    if (t.status != db::TrialStatus::kAborted) continue;
    ++aborted;
    EXPECT_THAT(t.abort_reason, MatchesRegex("device read hung for 1[0-4][0-9][0-9] ms"));
    EXPECT_EQ(study.samples(t.id, 0).size(), 200u);
  }
  EXPECT_EQ(aborted, 1);
}

TEST_F(DevicePluginSessionTest, APluginThatCrashesInConfigureStartsNothing) {
  const std::string db = create_study("crash.db");
  const auto [status, out] = testing::run_cli(
      kBinary, "session run --db " + db + " --participant S1 --training-trials 0 --max-trials 1 --device plugin:" +
                   kFake + " --device-option fault=crash_in_configure");
  EXPECT_EQ(status, 1) << out;
  EXPECT_THAT(out, HasSubstr("plugin " + kFake + " crashed (SIGSEGV) in configure; nothing was started"));
  db::StudyDb d = open_read_only(db);
  for (const auto& t : d.trials()) EXPECT_EQ(t.status, db::TrialStatus::kPlanned) << t.id;
}

}  // namespace
}  // namespace hapticlab
