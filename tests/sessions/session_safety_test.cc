// Safety at the session level: a device that is not calibrated is refused
// before anything is recorded for the trial, and the protocol's "safety"
// limits reach every command the device gets.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "sessions/session_runner.h"
#include "tests/sessions/session_fixture.h"

namespace hapticlab::sessions {
namespace {

using db::TrialStatus;
using testing::SessionFixture;

using testing::options_for;

std::vector<db::TrialRow> trials_of(const std::filesystem::path& db_path) {
  db::OpenOptions open;
  open.recover = false;
  db::StudyDb db(db_path, open);
  return db.trials(db.studies().front().id);
}

int count(const std::vector<db::TrialRow>& trials, const std::string& code, TrialStatus status) {
  int n = 0;
  for (const auto& t : trials) n += t.participant_code == code && t.status == status ? 1 : 0;
  return n;
}

TEST_F(SessionFixture, NotCalibratedDeviceIsRefusedAndTheTrialStaysPlanned) {
  SessionOptions o = options_for("A1");
  int configured = 0;
  o.configure_trial = [&](SimTrialConfig& c, const db::TrialRow&) {
    if (++configured == 2) c.inject_fault = std::make_pair(DeviceStatus::kNotCalibrated, 0.0);
  };
  std::int64_t session_id = 0;
  try {
    run_session(db_path_, o);
    FAIL() << "the session ran on a device that is not calibrated";
  } catch (const DeviceNotReadyError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("the sim device is not calibrated/homed; calibrate it, then run the session again"),
              std::string::npos)
        << message;
    EXPECT_NE(message.find("was not started and stays planned"), std::string::npos) << message;
  }
  // The first trial ran; the second was never started, aborted or re-queued.
  const auto trials = trials_of(db_path_);
  EXPECT_EQ(count(trials, "A1", TrialStatus::kComplete), 1);
  EXPECT_EQ(count(trials, "A1", TrialStatus::kPlanned), 3);
  EXPECT_EQ(count(trials, "A1", TrialStatus::kAborted), 0);
  EXPECT_EQ(count(trials, "A1", TrialStatus::kRunning), 0);
  {
    db::StudyDb db(db_path_);
    db::Statement q = db.connection().prepare("SELECT id FROM session");
    ASSERT_TRUE(q.step());
    session_id = q.column_int64(0);
    EXPECT_FALSE(q.step());  // one session
    EXPECT_EQ(db.session(session_id).status, db::SessionStatus::kInterrupted);
  }
  // Calibrated again: the same command continues with the planned trial.
  const SessionResult r = run_session(db_path_, options_for("A1"));
  EXPECT_EQ(r.trials_complete, 3);
  EXPECT_EQ(r.trials_left, 0);
}

// The largest |joint_force| of each kind over every stored sample of A1's
// trials run so far: insertion [N], pitch/yaw [N·m].
std::pair<double, double> peak_commands(const std::filesystem::path& db_path) {
  db::StudyDb db(db_path);
  double insertion = 0.0, pitch_yaw = 0.0;
  std::size_t n = 0;
  for (const auto& t : db.trials(db.studies().front().id)) {
    if (t.participant_code != "A1" || t.status == TrialStatus::kPlanned) continue;
    for (int i = 0; i < 2; ++i)
      for (const db::StoredSample& s : db.samples(t.id, i)) {
        insertion = std::max(insertion, std::abs(s.value.joint_force[0]));
        pitch_yaw = std::max({pitch_yaw, std::abs(s.value.joint_force[1]), std::abs(s.value.joint_force[2])});
        ++n;
      }
  }
  EXPECT_GT(n, 1000u);
  return {insertion, pitch_yaw};
}

TEST_F(SessionFixture, ProtocolSafetyLimitsBoundEveryCommandOfTheSession) {
  constexpr double kInsertionLimit_N = 0.3, kPitchYawLimit_Nm = 0.01;
  // Float32 storage of the physical channels: 1e-6 relative.
  constexpr double kStored = 1e-6;
  SessionOptions o = options_for("A1");
  // The first block: one trial of each setting, High Fidelity among them
  // (the other has no force feedback at all).
  o.max_trials = 2;
  o.max_trial_s = 20.0;
  run_session(db_path_, o);
  const auto [free_insertion, free_pitch_yaw] = peak_commands(db_path_);
  // Without limits the task pushes harder than the limits below: they bite.
  EXPECT_GT(free_insertion, 2 * kInsertionLimit_N);
  EXPECT_GT(free_pitch_yaw, 2 * kPitchYawLimit_Nm);

  // The same study with a "safety" object.
  std::ifstream in(protocol_);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto close = text.rfind('}');
  text.insert(close, R"(, "safety": {"max_insertion_force_N": 0.3, "max_pitch_yaw_torque_Nm": 0.01})");
  const std::filesystem::path limited_protocol = dir_ / "limited.json";
  std::ofstream(limited_protocol) << text;
  const std::filesystem::path limited_db = dir_ / "limited.db";
  {
    db::StudyDb db(limited_db);
    create_study(db, limited_protocol, "test");
  }
  run_session(limited_db, o);
  const auto [insertion, pitch_yaw] = peak_commands(limited_db);
  EXPECT_LE(insertion, kInsertionLimit_N * (1 + kStored));
  EXPECT_GE(insertion, kInsertionLimit_N * (1 - kStored));  // reached: the limit is applied
  EXPECT_LE(pitch_yaw, kPitchYawLimit_Nm * (1 + kStored));
  EXPECT_GE(pitch_yaw, kPitchYawLimit_Nm * (1 - kStored));
}

}  // namespace
}  // namespace hapticlab::sessions
