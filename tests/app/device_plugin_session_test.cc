// `session run --device plugin:hapticlab_sim_device.so` through the real
// binary: the same samples as the built-in sim, and a plugin that crashes
// stops the session before anything is stored.
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/cli_process.h"
#include "db/study_db.h"
#include "tests/testing/test_paths.h"

namespace hapticlab {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;


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

TEST_F(DevicePluginSessionTest, AReadingThatJumpsStopsTheTrialWhichIsRequeuedWithItsReason) {
  const std::string db = create_study("jump.db");
  const auto [status, out] = testing::run_cli(
      kBinary, "session run --db " + db + " --participant S1 --training-trials 0 --max-trials 1 --max-trial-s 5" +
                   " --device plugin:" + kFake + " --device-option fault=jump");
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

TEST_F(DevicePluginSessionTest, ThePluginSessionLogsTheSameSamplesAsTheBuiltInSim) {
  const std::string sim_db = create_study("sim.db"), plugin_db = create_study("plugin.db");
  const std::string run = " --participant S1 --training-trials 0 --max-trials 2 --max-trial-s 4 --clock virtual";
  const auto [s1, out1] = testing::run_cli(kBinary, "session run --db " + sim_db + run + " --device sim");
  ASSERT_EQ(s1, 0) << out1;
  const auto [s2, out2] = testing::run_cli(kBinary, "session run --db " + plugin_db + run +
                                                        " --device plugin:" + kSimPlugin +
                                                        " --device-option max_substep_s=1e-3");
  ASSERT_EQ(s2, 0) << out2;

  db::StudyDb a = open_read_only(sim_db), b = open_read_only(plugin_db);
  std::vector<db::TrialRow> trials_a, trials_b;
  for (const auto& t : a.trials())
    if (t.status != db::TrialStatus::kPlanned) trials_a.push_back(t);
  for (const auto& t : b.trials())
    if (t.status != db::TrialStatus::kPlanned) trials_b.push_back(t);
  ASSERT_EQ(trials_a.size(), 2u);
  ASSERT_EQ(trials_b.size(), 2u);
  std::size_t compared = 0;
  for (std::size_t k = 0; k < trials_a.size(); ++k) {
    ASSERT_EQ(trials_a[k].id, trials_b[k].id);
    EXPECT_EQ(trials_a[k].status, trials_b[k].status);
    for (int instrument = 0; instrument < 2; ++instrument) {
      const auto sa = a.samples(trials_a[k].id, instrument), sb = b.samples(trials_b[k].id, instrument);
      ASSERT_EQ(sa.size(), sb.size()) << "trial " << trials_a[k].id;
      // Trials of up to 4 s at 1 kHz with a moving participant.
      ASSERT_GT(sa.size(), 500u);
      for (std::size_t i = 0; i < sa.size(); ++i)
        ASSERT_NO_FATAL_FAILURE(expect_same(sa[i], sb[i], "trial " + std::to_string(trials_a[k].id) +
                                                              " instrument " + std::to_string(instrument) +
                                                              " sample " + std::to_string(i)));
      compared += sa.size();
    }
  }
  EXPECT_GT(compared, 2000u);
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
