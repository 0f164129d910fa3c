// The C study API (hapticlab/study.h) against a real study database: calls
// out of order are refused and lose nothing, the operator stop zeroes the
// trial engine's force from its next update, and the bookkeeping (blinding,
// re-queueing, the time-limit rule, one session per participant) is that of
// `session run`.
#include "hapticlab/study.h"

#include <chrono>
#include <filesystem>
#include <fstream>
#include <cmath>
#include <limits>
#include <vector>
#include <string>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "db/sqlite_handle.h"
#include "db/study_db.h"
#include "tests/sessions/session_fixture.h"

namespace hapticlab::sessions {
namespace {

using ::testing::HasSubstr;
using testing::SessionFixture;

// A valid sample of update `tick` at 1 kHz: both tools still, a VE force of
// 1 N along z on the left one.
hl_sample sample_at(std::uint64_t tick) {
  hl_sample s{};
  s.tick = tick;
  s.dt_s = 0.001;
  s.t_s = 0.001 * static_cast<double>(tick);
  for (hl_sample_instrument& in : s.instrument) {
    in.raw_joints[0] = in.degraded_joints[0] = 0.1;
    in.tip_position_m[2] = -0.1;
  }
  s.instrument[0].ve_force_N[2] = 1.0;
  return s;
}

class StudyApiTest : public SessionFixture {
 protected:
  void SetUp() override {
    SessionFixture::SetUp();
    study_ = hl_study_open(db_path_.c_str(), error_, sizeof error_);
    ASSERT_NE(study_, nullptr) << error_;
  }
  void TearDown() override {
    hl_study_close(study_);
    SessionFixture::TearDown();
  }
  // Logs one sample, then ends the open trial complete (or by a time
  // limit): a trial of which nothing was logged can be neither.
  int complete_trial(int outcome = HL_TRIAL_COMPLETE, const char* reason = nullptr) {
    const hl_sample s = sample_at(0);
    if (const int r = hl_study_log_sample(study_, &s); r != HL_OK) return r;
    return hl_study_end_trial(study_, outcome, reason, error_, sizeof error_);
  }
  db::StudyDb open_db() {
    db::OpenOptions o;
    o.recover = false;
    return db::StudyDb(db_path_, o);
  }

  hl_study* study_ = nullptr;
  char error_[512] = "";
  hl_trial trial_{};
  char setting_[128] = "";
};

TEST_F(StudyApiTest, CallsOutOfOrderAreRefusedAndLoseNothing) {
  const hl_sample s = sample_at(0);
  // Before a session.
  EXPECT_EQ(hl_study_next_trial(study_, &trial_, setting_, sizeof setting_, error_, sizeof error_), HL_ERROR_STATE);
  EXPECT_THAT(error_, HasSubstr("no session is open"));
  EXPECT_EQ(hl_study_log_sample(study_, &s), HL_ERROR_STATE);
  EXPECT_EQ(hl_study_end_trial(study_, HL_TRIAL_COMPLETE, nullptr, error_, sizeof error_), HL_ERROR_STATE);
  EXPECT_EQ(hl_study_end_session(study_, error_, sizeof error_), HL_ERROR_STATE);
  EXPECT_EQ(hl_study_start_session(study_, "ZZ9", nullptr, error_, sizeof error_), HL_ERROR_STUDY);
  EXPECT_THAT(error_, HasSubstr("'ZZ9' is not in study"));
  EXPECT_THAT(error_, HasSubstr("A1, B2"));
  // NULL handles and arguments.
  EXPECT_EQ(hl_study_open(nullptr, error_, sizeof error_), nullptr);
  EXPECT_EQ(hl_study_open((dir_ / "missing.db").c_str(), error_, sizeof error_), nullptr);
  EXPECT_THAT(error_, HasSubstr("no such database"));
  EXPECT_EQ(hl_study_start_session(nullptr, "A1", nullptr, error_, sizeof error_), HL_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hl_study_log_sample(nullptr, &s), HL_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hl_study_log_sample(study_, nullptr), HL_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hl_study_next_trial(study_, nullptr, nullptr, 0, error_, sizeof error_), HL_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hl_study_request_stop(nullptr), HL_ERROR_INVALID_ARGUMENT);

  ASSERT_EQ(hl_study_start_session(study_, "A1", nullptr, error_, sizeof error_), HL_OK) << error_;
  EXPECT_EQ(hl_study_start_session(study_, "A1", nullptr, error_, sizeof error_), HL_ERROR_STATE);
  ASSERT_EQ(hl_study_next_trial(study_, &trial_, setting_, sizeof setting_, error_, sizeof error_), HL_OK) << error_;
  const std::int64_t first = trial_.trial_id;
  // A trial is open: no second one, no end of session, no abort without a reason.
  hl_trial other{};
  EXPECT_EQ(hl_study_next_trial(study_, &other, nullptr, 0, error_, sizeof error_), HL_ERROR_STATE);
  EXPECT_THAT(error_, HasSubstr("is still open"));
  EXPECT_EQ(hl_study_end_session(study_, error_, sizeof error_), HL_ERROR_STATE);
  EXPECT_EQ(hl_study_end_trial(study_, HL_TRIAL_ABORTED, nullptr, error_, sizeof error_), HL_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hl_study_end_trial(study_, 7, nullptr, error_, sizeof error_), HL_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hl_study_log_event(study_, 0.0, HL_EVENT_CONTACT_START, 2, 0), HL_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hl_study_log_event(study_, NAN, HL_EVENT_CONTACT_START, 0, 0), HL_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hl_study_log_event(study_, 0.0, 10, -1, 0), HL_ERROR_INVALID_ARGUMENT);  // operator_abort is the API's
  // ... and everything of the open trial still counts.
  constexpr int kUpdates = 250;
  for (int k = 0; k < kUpdates; ++k) {
    const hl_sample sk = sample_at(static_cast<std::uint64_t>(k));
    ASSERT_EQ(hl_study_log_sample(study_, &sk), HL_OK);
  }
  EXPECT_EQ(hl_study_log_event(study_, 0.010, HL_EVENT_INSERTION_PASSED, 0, 0), HL_OK);
  ASSERT_EQ(hl_study_end_trial(study_, HL_TRIAL_COMPLETE, nullptr, error_, sizeof error_), HL_OK) << error_;
  EXPECT_EQ(hl_study_end_trial(study_, HL_TRIAL_COMPLETE, nullptr, error_, sizeof error_), HL_ERROR_STATE);
  EXPECT_EQ(hl_study_log_sample(study_, &s), HL_ERROR_STATE);
  ASSERT_EQ(hl_study_end_session(study_, error_, sizeof error_), HL_OK) << error_;
  EXPECT_EQ(hl_study_end_session(study_, error_, sizeof error_), HL_ERROR_STATE);

  db::StudyDb db = open_db();
  const db::TrialRow t = db.trial(first);
  EXPECT_EQ(t.status, db::TrialStatus::kComplete);
  EXPECT_EQ(t.position, 1);
  EXPECT_EQ(db.sample_count(first, 0), static_cast<std::uint64_t>(kUpdates));
  EXPECT_EQ(db.sample_count(first, 1), static_cast<std::uint64_t>(kUpdates));
  const std::vector<db::EventRow> events = db.events(first);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].type, "insertion_passed_20mm");
  EXPECT_DOUBLE_EQ(events[0].t_s, 0.010);
  // The sample content round-trips (stored as float: 1 N exactly).
  EXPECT_EQ(db.samples(first, 0)[7].value.ve_force_N[2], 1.0);
  int running_or_done = 0;
  for (const db::TrialRow& r : db.trials())
    if (r.participant_code == "A1" && r.status != db::TrialStatus::kPlanned) ++running_or_done;
  EXPECT_EQ(running_or_done, 1);  // nothing else was started by the refused calls
  EXPECT_EQ(db.session(*t.session_id).status, db::SessionStatus::kClosed);
}

// Issue 33: one repeated tick used to pass (HL_OK), then fail the whole
// trial at hl_study_end_trial as a storage failure (513 samples lost, the
// session over). A sample that cannot be stored where it says, and an
// event type study.h does not define, are refused at the call and counted;
// the trial goes on and is stored whole.
TEST_F(StudyApiTest, ARepeatedTickOrAnUndefinedEventIsRefusedAtTheCallAndTheTrialGoesOn) {
  ASSERT_EQ(hl_study_start_session(study_, "A1", nullptr, error_, sizeof error_), HL_OK) << error_;
  ASSERT_EQ(hl_study_next_trial(study_, &trial_, setting_, sizeof setting_, error_, sizeof error_), HL_OK) << error_;
  int refused = 0;
  for (std::uint64_t k = 0; k < 600; ++k) {
    const hl_sample sk = sample_at(k);
    ASSERT_EQ(hl_study_log_sample(study_, &sk), HL_OK);
    if (k == 100 || k == 300) {  // the same update again, and a counter that went back
      const hl_sample again = sample_at(k == 100 ? k : k - 50);
      EXPECT_EQ(hl_study_log_sample(study_, &again), HL_ERROR_INVALID_ARGUMENT);
      ++refused;
    }
  }
  hl_sample no_time = sample_at(600);
  no_time.t_s = NAN;
  EXPECT_EQ(hl_study_log_sample(study_, &no_time), HL_ERROR_INVALID_ARGUMENT);
  ++refused;
  // Each of these would be stored, exported and analysed as a value: a
  // non-finite joint or force, a time that goes back, a negative period, a
  // tick past the file's 64-bit signed ticks.
  const std::vector<void (*)(hl_sample&)> wrong = {
      [](hl_sample& s) { s.instrument[0].raw_joints[0] = NAN; },
      [](hl_sample& s) { s.instrument[1].displayed_force_N[2] = INFINITY; },
      [](hl_sample& s) { s.instrument[0].joint_force[0] = NAN; },
      [](hl_sample& s) { s.instrument[1].tip_velocity_m_per_s[1] = -INFINITY; },
      // Finite, but beyond float32, as which they are stored: infinity.
      [](hl_sample& s) { s.instrument[0].ve_force_N[2] = 1e39; },
      [](hl_sample& s) { s.instrument[1].tip_position_m[0] = -4e38; },
      [](hl_sample& s) { s.instrument[0].raw_joints[3] = 1e300; },
      [](hl_sample& s) { s.t_s = -5.0; },
      [](hl_sample& s) { s.dt_s = -1e-3; },
      [](hl_sample& s) { s.tick = std::numeric_limits<std::uint64_t>::max() - 1; },
      // The largest signed tick: its chunk would end one past it, which
      // every reader calls damaged, and the trial would lose its measures.
      [](hl_sample& s) { s.tick = static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()); }};
  for (std::size_t i = 0; i < wrong.size(); ++i) {
    hl_sample s = sample_at(600);
    wrong[i](s);
    EXPECT_EQ(hl_study_log_sample(study_, &s), HL_ERROR_INVALID_ARGUMENT) << "case " << i;
    ++refused;
  }
  // 6..8 are the simulated VE's own types (tissue_removed, clip_applied,
  // clip_missed), 10 is operator_abort: none is defined by study.h.
  for (int type : {6, 7, 8, 10, 11, -1})
    EXPECT_EQ(hl_study_log_event(study_, 0.2, type, -1, 0), HL_ERROR_INVALID_ARGUMENT) << "type " << type;
  // The task's completion is the task's, a contact an instrument's; an item
  // number is never negative.
  EXPECT_EQ(hl_study_log_event(study_, 0.2, HL_EVENT_TASK_COMPLETE, 0, 0), HL_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hl_study_log_event(study_, 0.2, HL_EVENT_CONTACT_START, -1, 0), HL_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hl_study_log_event(study_, 0.2, HL_EVENT_CONTACT_START, 0, -3), HL_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hl_study_log_event(study_, 0.010, HL_EVENT_INSERTION_PASSED, 0, 0), HL_OK);
  std::uint64_t rejected_samples = 0, rejected_events = 0;
  ASSERT_EQ(hl_study_rejected(study_, &rejected_samples, &rejected_events), HL_OK);
  EXPECT_EQ(rejected_samples, static_cast<std::uint64_t>(refused));
  EXPECT_EQ(rejected_events, 9u);
  const std::int64_t id = trial_.trial_id;
  ASSERT_EQ(hl_study_end_trial(study_, HL_TRIAL_COMPLETE, nullptr, error_, sizeof error_), HL_OK) << error_;
  // The session goes on: the next trial starts.
  ASSERT_EQ(hl_study_next_trial(study_, &trial_, setting_, sizeof setting_, error_, sizeof error_), HL_OK) << error_;
  ASSERT_EQ(hl_study_end_trial(study_, HL_TRIAL_ABORTED, "test over", error_, sizeof error_), HL_OK) << error_;
  ASSERT_EQ(hl_study_end_session(study_, error_, sizeof error_), HL_OK) << error_;

  db::StudyDb db = open_db();
  EXPECT_EQ(db.trial(id).status, db::TrialStatus::kComplete);
  EXPECT_EQ(db.sample_count(id, 0), 600u);
  EXPECT_EQ(db.sample_count(id, 1), 600u);
  const auto counters = db.device_counters(id);
  const auto counter = [&](const std::string& name) {
    for (const auto& [n, v] : counters)
      if (n == name) return static_cast<std::int64_t>(v);
    return std::int64_t{-1};
  };
  EXPECT_EQ(counter("rejected_samples"), refused);
  EXPECT_EQ(counter("rejected_events"), 9);
  ASSERT_EQ(db.events(id).size(), 1u);
}

// A trial ended complete with no sample logged used to be stored complete:
// the schedule counted it done and every metric left it out ("no samples
// logged"), so the participant's slot was lost without a word. Refused,
// the trial still open; a stop still ends it (as aborted) without samples.
TEST_F(StudyApiTest, ACompleteTrialWithoutASampleIsRefusedAndStaysOpen) {
  ASSERT_EQ(hl_study_start_session(study_, "A1", nullptr, error_, sizeof error_), HL_OK) << error_;
  ASSERT_EQ(hl_study_next_trial(study_, &trial_, setting_, sizeof setting_, error_, sizeof error_), HL_OK) << error_;
  const std::int64_t id = trial_.trial_id;
  EXPECT_EQ(hl_study_end_trial(study_, HL_TRIAL_COMPLETE, nullptr, error_, sizeof error_), HL_ERROR_STATE);
  EXPECT_THAT(error_, HasSubstr("trial " + std::to_string(id) + " cannot be complete: no sample of it was logged"));
  EXPECT_THAT(error_, HasSubstr("0 refused as invalid, 0 dropped"));
  // Refused samples are not logged ones, and the message counts them.
  hl_sample bad = sample_at(0);
  bad.t_s = NAN;
  ASSERT_EQ(hl_study_log_sample(study_, &bad), HL_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hl_study_end_trial(study_, HL_TRIAL_COMPLETE, nullptr, error_, sizeof error_), HL_ERROR_STATE);
  EXPECT_THAT(error_, HasSubstr("1 refused as invalid"));
  // A time limit would close the slot as surely.
  EXPECT_EQ(hl_study_end_trial(study_, HL_TRIAL_TIME_LIMIT, "90 s", error_, sizeof error_), HL_ERROR_STATE);
  EXPECT_THAT(error_, HasSubstr("cannot be closed by a time limit: no sample of it was logged"));
  // Still open: it takes samples and then ends complete.
  ASSERT_EQ(complete_trial(), HL_OK) << error_;
  // The next trial, with nothing logged, can still be aborted or stopped.
  ASSERT_EQ(hl_study_next_trial(study_, &trial_, setting_, sizeof setting_, error_, sizeof error_), HL_OK) << error_;
  const std::int64_t stopped = trial_.trial_id;
  ASSERT_EQ(hl_study_request_stop(study_), HL_OK);
  ASSERT_EQ(hl_study_end_trial(study_, HL_TRIAL_COMPLETE, nullptr, error_, sizeof error_), HL_OK) << error_;
  ASSERT_EQ(hl_study_end_session(study_, error_, sizeof error_), HL_OK) << error_;

  db::StudyDb db = open_db();
  EXPECT_EQ(db.trial(id).status, db::TrialStatus::kComplete);
  EXPECT_EQ(db.sample_count(id, 0), 1u);
  EXPECT_EQ(db.trial(stopped).status, db::TrialStatus::kAborted);
}

TEST_F(StudyApiTest, TrialsComeInScheduleOrderBlindedWithTheirSettingsEngine) {
  ASSERT_EQ(hl_study_start_session(study_, "A1", "test rig", error_, sizeof error_), HL_OK) << error_;
  db::StudyDb db = open_db();
  std::vector<db::TrialRow> planned;
  for (const db::TrialRow& r : db.trials())
    if (r.participant_code == "A1") planned.push_back(r);
  for (std::size_t i = 0; i < planned.size(); ++i) {
    ASSERT_EQ(hl_study_next_trial(study_, &trial_, setting_, sizeof setting_, error_, sizeof error_), HL_OK);
    EXPECT_EQ(trial_.trial_id, planned[i].id);
    EXPECT_STREQ(trial_.task, "dissection");
    EXPECT_EQ(trial_.repetition, planned[i].repetition);
    EXPECT_EQ(trial_.trial_number, static_cast<int>(i) + 1);
    EXPECT_EQ(trial_.trial_count, 4);
    EXPECT_EQ(std::string(setting_), planned[i].setting_name);  // the operator's view
    // The trial's setting is what the study stores as felt, and its ramp-in
    // is the loop's safety: the application changes neither (it could, and
    // the trial was filed under a setting its participant never felt).
    EXPECT_EQ(hl_engine_set_settings(trial_.engine, "{}", error_, sizeof error_), HL_ERROR_SETTINGS);
    EXPECT_THAT(std::string(error_), HasSubstr("this engine's settings are fixed"));
    EXPECT_EQ(hl_engine_set_ramp_in(trial_.engine, 0.0), HL_ERROR_INVALID_ARGUMENT);
    EXPECT_EQ(hl_engine_set_ramp_in(trial_.engine, 0.29), HL_ERROR_INVALID_ARGUMENT);
    // The engine has the trial's setting: without force feedback a VE force
    // of 2 N never reaches the device; at high fidelity it does (the first
    // update re-anchors, so look at the second).
    hl_input in{};
    in.dt_s = 0.001;
    in.insertion_m = 0.1;
    in.ve_force_N[2] = 2.0;
    hl_output out{};
    ASSERT_EQ(hl_engine_update(trial_.engine, 0, &in, &out), HL_OK);
    ASSERT_EQ(hl_engine_update(trial_.engine, 0, &in, &out), HL_OK);
    if (planned[i].setting_name == "No Force Feedback") {
      EXPECT_EQ(out.displayed_force_N[2], 0.0);
    } else {
      // Each trial's force ramps in over 0.3 s, as in HapticLab's own loop:
      // the second update starts 1 ms into the trial, so 1/300 of it.
      EXPECT_NEAR(out.displayed_force_N[2], 2.0 * 0.001 / 0.3, 1e-12) << planned[i].setting_name;
      EXPECT_NE(out.status & HL_RAMPING, 0u);
      for (int k = 0; k < 300; ++k) ASSERT_EQ(hl_engine_update(trial_.engine, 0, &in, &out), HL_OK);
      EXPECT_NEAR(out.displayed_force_N[2], 2.0, 1e-9) << planned[i].setting_name;
      EXPECT_EQ(out.status & HL_RAMPING, 0u);
    }
    ASSERT_EQ(complete_trial(), HL_OK) << error_;
  }
  EXPECT_EQ(hl_study_next_trial(study_, &trial_, nullptr, 0, error_, sizeof error_), HL_STUDY_DONE);
  EXPECT_EQ(hl_study_end_session(study_, error_, sizeof error_), HL_OK);
  EXPECT_EQ(open_db().session(1).device, "test rig");
}

TEST_F(StudyApiTest, OperatorStopZeroesTheForceFromTheNextUpdateAndRequeuesTheTrial) {
  ASSERT_EQ(hl_study_start_session(study_, "A1", nullptr, error_, sizeof error_), HL_OK) << error_;
  // Find a trial whose setting displays the VE force.
  for (;;) {
    ASSERT_EQ(hl_study_next_trial(study_, &trial_, setting_, sizeof setting_, error_, sizeof error_), HL_OK);
    if (std::string(setting_) == "High Fidelity") break;
    ASSERT_EQ(complete_trial(), HL_OK) << error_;
  }
  const std::int64_t stopped = trial_.trial_id;
  hl_input in{};
  in.dt_s = 0.001;
  in.insertion_m = 0.1;
  in.ve_force_N[2] = 2.0;
  hl_output out{};
  for (std::uint64_t k = 0; k < 310; ++k) {  // past the 0.3 s ramp-in
    ASSERT_EQ(hl_engine_update(trial_.engine, 0, &in, &out), HL_OK);
    if (k < 3) {
      const hl_sample s = sample_at(k);
      ASSERT_EQ(hl_study_log_sample(study_, &s), HL_OK);
    }
  }
  ASSERT_NEAR(out.displayed_force_N[2], 2.0, 1e-9);
  ASSERT_EQ(out.status & HL_HALTED, 0u);

  std::thread button([&] { EXPECT_EQ(hl_study_request_stop(study_), HL_OK); });  // the operator's thread
  button.join();
  for (int instrument : {0, 1}) {
    ASSERT_EQ(hl_engine_update(trial_.engine, instrument, &in, &out), HL_OK);
    EXPECT_EQ(out.displayed_force_N[0], 0.0);
    EXPECT_EQ(out.displayed_force_N[1], 0.0);
    EXPECT_EQ(out.displayed_force_N[2], 0.0);
    EXPECT_EQ(out.insertion_force_N, 0.0);
    EXPECT_EQ(out.pitch_torque_Nm, 0.0);
    EXPECT_EQ(out.yaw_torque_Nm, 0.0);
    EXPECT_NE(out.status & HL_HALTED, 0u);
    EXPECT_NEAR(out.degraded_insertion_m, 0.1, 1e-6);  // the VE still gets positions
    // The second half of an update cannot bring the force back.
    const double ve[3] = {0.0, 0.0, 3.0};
    ASSERT_EQ(hl_engine_refresh_forces(trial_.engine, instrument, ve, &out), HL_OK);
    EXPECT_EQ(out.displayed_force_N[2], 0.0);
  }
  // The application ends the trial as it would; it is the operator's abort.
  ASSERT_EQ(hl_study_end_trial(study_, HL_TRIAL_COMPLETE, nullptr, error_, sizeof error_), HL_OK) << error_;
  EXPECT_EQ(hl_study_next_trial(study_, &trial_, nullptr, 0, error_, sizeof error_), HL_STUDY_STOPPED);
  ASSERT_EQ(hl_study_end_session(study_, error_, sizeof error_), HL_OK);

  db::StudyDb db = open_db();
  const db::TrialRow t = db.trial(stopped);
  EXPECT_EQ(t.status, db::TrialStatus::kAborted);
  EXPECT_EQ(t.abort_reason, "operator stopped the session");
  const std::vector<db::EventRow> events = db.events(stopped);
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.back().type, "operator_abort");
  EXPECT_DOUBLE_EQ(events.back().t_s, 0.002);  // the last logged sample's time
  int copies = 0;
  for (const db::TrialRow& r : db.trials())
    if (r.participant_code == "A1" && r.position == t.position && r.status == db::TrialStatus::kPlanned) ++copies;
  EXPECT_EQ(copies, 1);  // re-queued at its place
}

// A stop answered HL_OK is never forgotten: one requested before the
// session started (or while it was starting) held for nothing before, and
// the next trial ran at full force. It now stops the session's first trial;
// once that session is ended the stop has done its work.
TEST_F(StudyApiTest, AStopBeforeTheSessionStartsHoldsForItsFirstTrial) {
  ASSERT_EQ(hl_study_request_stop(study_), HL_OK);
  ASSERT_EQ(hl_study_start_session(study_, "A1", nullptr, error_, sizeof error_), HL_OK) << error_;
  EXPECT_EQ(hl_study_next_trial(study_, &trial_, nullptr, 0, error_, sizeof error_), HL_STUDY_STOPPED);
  EXPECT_THAT(std::string(error_), HasSubstr("operator stopped the session"));
  ASSERT_EQ(hl_study_end_session(study_, error_, sizeof error_), HL_OK) << error_;
  ASSERT_EQ(hl_study_start_session(study_, "A1", nullptr, error_, sizeof error_), HL_OK) << error_;
  ASSERT_EQ(hl_study_next_trial(study_, &trial_, nullptr, 0, error_, sizeof error_), HL_OK) << error_;
  ASSERT_EQ(complete_trial(), HL_OK) << error_;
  // A stop between sessions likewise.
  ASSERT_EQ(hl_study_end_session(study_, error_, sizeof error_), HL_OK) << error_;
  ASSERT_EQ(hl_study_request_stop(study_), HL_OK);
  ASSERT_EQ(hl_study_start_session(study_, "A1", nullptr, error_, sizeof error_), HL_OK) << error_;
  EXPECT_EQ(hl_study_next_trial(study_, &trial_, nullptr, 0, error_, sizeof error_), HL_STUDY_STOPPED);
  ASSERT_EQ(hl_study_end_session(study_, error_, sizeof error_), HL_OK) << error_;
  int complete = 0;
  for (const db::TrialRow& r : open_db().trials()) complete += r.status == db::TrialStatus::kComplete;
  EXPECT_EQ(complete, 1);
}

// Text the API stores must be storable: a reason of white space only was
// stored as an abort's reason, a complete trial's reason was dropped, and
// bytes that are not UTF-8 went into the file as they came. Each is refused
// naming what is wrong, the trial still open; NULL or "" still complete it.
TEST_F(StudyApiTest, TextThatCannotBeStoredIsRefusedAndTheTrialStaysOpen) {
  EXPECT_EQ(hl_study_start_session(study_, "A1", "dev\xff\xfe", error_, sizeof error_), HL_ERROR_INVALID_ARGUMENT);
  EXPECT_THAT(std::string(error_), HasSubstr("device is not a printable UTF-8 name"));
  for (const char* forged : {"dev\nP02 accepted", "dev\xC2\x9B" "31m", "dev\xE2\x80\xAE" "lanigiro"})
    EXPECT_EQ(hl_study_start_session(study_, "A1", forged, error_, sizeof error_), HL_ERROR_INVALID_ARGUMENT)
        << forged;
  ASSERT_EQ(hl_study_start_session(study_, "A1", "Phantom \xC2\xB5", error_, sizeof error_), HL_OK) << error_;
  ASSERT_EQ(hl_study_next_trial(study_, &trial_, nullptr, 0, error_, sizeof error_), HL_OK) << error_;
  const hl_sample s = sample_at(0);
  ASSERT_EQ(hl_study_log_sample(study_, &s), HL_OK);
  const struct {
    int outcome;
    const char* reason;
    const char* says;
  } refused[] = {
      {HL_TRIAL_ABORTED, " \t ", "only white space"},
      {HL_TRIAL_ABORTED, "tool \xff dropped", "not valid UTF-8"},
      {HL_TRIAL_TIME_LIMIT, "\xC3", "not valid UTF-8"},
      {HL_TRIAL_COMPLETE, "the participant finished early", "a complete trial stores no reason"},
  };
  for (const auto& r : refused) {
    EXPECT_EQ(hl_study_end_trial(study_, r.outcome, r.reason, error_, sizeof error_), HL_ERROR_INVALID_ARGUMENT)
        << r.reason;
    EXPECT_THAT(std::string(error_), HasSubstr(r.says));
    EXPECT_THAT(std::string(error_), HasSubstr("the trial is still open"));
  }
  const std::int64_t first = trial_.trial_id;
  ASSERT_EQ(hl_study_end_trial(study_, HL_TRIAL_COMPLETE, "", error_, sizeof error_), HL_OK) << error_;
  ASSERT_EQ(hl_study_next_trial(study_, &trial_, nullptr, 0, error_, sizeof error_), HL_OK) << error_;
  ASSERT_EQ(hl_study_end_trial(study_, HL_TRIAL_ABORTED, "Pinzette gelöst", error_, sizeof error_), HL_OK)
      << error_;
  ASSERT_EQ(hl_study_end_session(study_, error_, sizeof error_), HL_OK) << error_;
  db::StudyDb db = open_db();
  EXPECT_EQ(db.trial(first).status, db::TrialStatus::kComplete);
  EXPECT_EQ(db.trial(trial_.trial_id).abort_reason, "Pinzette gelöst");
}

// hl_study_open promises that nothing changes until a session starts: an
// empty file (a `touch`ed name) was given a whole schema before the open
// was refused.
TEST_F(StudyApiTest, OpeningAnEmptyFileRefusesItAndLeavesItEmpty) {
  const std::filesystem::path empty = std::filesystem::path(db_path_).parent_path() / "empty.db";
  { std::ofstream touch(empty); }
  EXPECT_EQ(hl_study_open(empty.c_str(), error_, sizeof error_), nullptr);
  EXPECT_THAT(std::string(error_), HasSubstr("the file is empty"));
  EXPECT_EQ(std::filesystem::file_size(empty), 0u);
}

// The trial's loop_timing (the rate a study cites) is made from dt_s, the
// analysis from t_s: a dt_s left at 0, or given in milliseconds, stored a
// period of 0 or of 1 s for a 1 kHz trial without a word. The trial is kept
// (its times are right), and it says so: a loop_timing_mismatch event and
// a note to the application. Logging every other update with the loop's
// own period agrees, as ticks count the updates.
TEST_F(StudyApiTest, ATrialWhosePeriodsDisagreeWithItsTimesSaysSo) {
  ASSERT_EQ(hl_study_start_session(study_, "A1", nullptr, error_, sizeof error_), HL_OK) << error_;
  const struct {
    double dt_s;
    std::uint64_t tick_step;
    bool mismatch;
  } cases[] = {{0.0, 1, true}, {1.0, 1, true}, {0.001, 2, false}, {0.0011, 1, false}};
  for (const auto& c : cases) {
    ASSERT_EQ(hl_study_next_trial(study_, &trial_, nullptr, 0, error_, sizeof error_), HL_OK) << error_;
    for (std::uint64_t k = 0; k < 200; ++k) {
      hl_sample s = sample_at(k * c.tick_step);
      s.dt_s = c.dt_s;
      ASSERT_EQ(hl_study_log_sample(study_, &s), HL_OK);
    }
    const std::int64_t id = trial_.trial_id;
    ASSERT_EQ(hl_study_end_trial(study_, HL_TRIAL_COMPLETE, nullptr, error_, sizeof error_), HL_OK) << error_;
    db::StudyDb db = open_db();
    bool flagged = false;
    for (const db::EventRow& e : db.events(id)) flagged = flagged || e.type == "loop_timing_mismatch";
    EXPECT_EQ(flagged, c.mismatch) << c.dt_s;
    if (c.mismatch) {
      EXPECT_THAT(std::string(error_), HasSubstr("dt_s and t_s disagree")) << c.dt_s;
      EXPECT_THAT(std::string(error_), HasSubstr("t_s advance 1 ms per update")) << c.dt_s;
    } else {
      EXPECT_STREQ(error_, "") << c.dt_s;
    }
    EXPECT_EQ(db.trial(id).status, db::TrialStatus::kComplete);
  }
  ASSERT_EQ(hl_study_end_session(study_, error_, sizeof error_), HL_OK) << error_;
}

TEST_F(StudyApiTest, HaltedEngineOutsideAStudy) {
  char err[256];
  hl_engine* e = hl_engine_create_from_file((testing::source_dir() / "examples/settings/all_degradations.json").c_str(),
                                            err, sizeof err);
  ASSERT_NE(e, nullptr) << err;
  hl_engine_halt(e);
  hl_engine_halt(nullptr);  // ignored
  hl_input in{};
  in.dt_s = 0.001;
  in.insertion_m = 0.1;
  in.ve_force_N[0] = 5.0;
  hl_output out{};
  for (int k = 0; k < 5; ++k) ASSERT_EQ(hl_engine_update(e, 1, &in, &out), HL_OK);
  EXPECT_EQ(std::hypot(out.displayed_force_N[0], out.displayed_force_N[1], out.displayed_force_N[2]), 0.0);
  EXPECT_NE(out.status & HL_HALTED, 0u);
  EXPECT_EQ(out.status & HL_FAULT_MASK, 0u);  // a stop, not an engine fault
  hl_engine_destroy(e);
}

TEST_F(StudyApiTest, AbortedTrialsAreRequeuedButATimeLimitClosesTheSlot) {
  ASSERT_EQ(hl_study_start_session(study_, "A1", nullptr, error_, sizeof error_), HL_OK) << error_;
  ASSERT_EQ(hl_study_next_trial(study_, &trial_, nullptr, 0, error_, sizeof error_), HL_OK);
  const std::int64_t aborted = trial_.trial_id;
  ASSERT_EQ(hl_study_end_trial(study_, HL_TRIAL_ABORTED, "participant felt unwell", error_, sizeof error_), HL_OK);
  // The re-queued copy comes next, at the same place in the schedule.
  ASSERT_EQ(hl_study_next_trial(study_, &trial_, nullptr, 0, error_, sizeof error_), HL_OK);
  const std::int64_t copy = trial_.trial_id;
  EXPECT_NE(copy, aborted);
  ASSERT_EQ(complete_trial(HL_TRIAL_TIME_LIMIT, "120 s"), HL_OK) << error_;
  ASSERT_EQ(hl_study_next_trial(study_, &trial_, nullptr, 0, error_, sizeof error_), HL_OK);
  const std::int64_t next = trial_.trial_id;
  ASSERT_EQ(complete_trial(), HL_OK) << error_;

  db::StudyDb db = open_db();
  EXPECT_EQ(db.trial(aborted).abort_reason, "participant felt unwell");
  EXPECT_EQ(db.trial(copy).position, db.trial(aborted).position);
  EXPECT_EQ(db.trial(copy).abort_reason, "time limit (120 s) reached before the task was complete");
  EXPECT_EQ(db.trial(next).position, db.trial(aborted).position + 1);  // the slot was closed, not re-queued
  // A second process (here: handle) cannot run the same participant meanwhile.
  hl_study* second = hl_study_open(db_path_.c_str(), error_, sizeof error_);
  ASSERT_NE(second, nullptr);
  EXPECT_EQ(hl_study_start_session(second, "A1", nullptr, error_, sizeof error_), HL_ERROR_BUSY);
  EXPECT_THAT(error_, HasSubstr("pid"));
  EXPECT_EQ(hl_study_start_session(second, "B2", nullptr, error_, sizeof error_), HL_OK) << error_;
  hl_study_close(second);  // ends B2's session as interrupted
  EXPECT_EQ(hl_study_end_session(study_, error_, sizeof error_), HL_OK);
}

TEST_F(StudyApiTest, LoggingNeverBlocksAndEveryDropIsCounted) {
  ASSERT_EQ(hl_study_start_session(study_, "A1", nullptr, error_, sizeof error_), HL_OK) << error_;
  ASSERT_EQ(hl_study_next_trial(study_, &trial_, nullptr, 0, error_, sizeof error_), HL_OK);
  // Far more than the queue holds (2^14), as fast as possible: whatever the
  // writer does not take in time is dropped, counted, and reported as such.
  constexpr std::uint64_t kPushed = 200'000;
  std::uint64_t accepted = 0, refused = 0;
  for (std::uint64_t k = 0; k < kPushed; ++k) {
    const hl_sample s = sample_at(k);
    const int rc = hl_study_log_sample(study_, &s);
    ASSERT_TRUE(rc == HL_OK || rc == HL_STUDY_DROPPED) << rc;
    (rc == HL_OK ? accepted : refused) += 1;
  }
  std::uint64_t dropped = 0;
  ASSERT_EQ(hl_study_dropped(study_, &dropped, nullptr), HL_OK);
  EXPECT_EQ(dropped, refused);
  RecordProperty("samples_dropped", std::to_string(refused));
  const std::int64_t id = trial_.trial_id;
  ASSERT_EQ(hl_study_end_trial(study_, HL_TRIAL_COMPLETE, nullptr, error_, sizeof error_), HL_OK) << error_;
  db::StudyDb db = open_db();
  EXPECT_EQ(db.sample_count(id, 0), accepted);  // every accepted sample is stored
  const std::optional<db::LoopTimingRow> timing = db.loop_timing(id);
  ASSERT_TRUE(timing.has_value());
  EXPECT_EQ(timing->dropped_samples, refused);
  ASSERT_TRUE(timing->timing.has_value());
  EXPECT_EQ(timing->timing->count, kPushed);  // the application's periods, all of them
  EXPECT_NEAR(timing->timing->mean_period_s, 0.001, 1e-12);
}

// The database fails mid-trial (a trigger refuses every chunk, as a full
// disk would): the log calls say so (HL_ERROR_DATABASE) within the writer's
// commit interval, instead of accepting updates that are thrown away until
// the trial's end; before, they answered HL_OK to the end.
TEST_F(StudyApiTest, OnceStorageFailsTheLogCallsSaySo) {
  ASSERT_EQ(hl_study_start_session(study_, "A1", nullptr, error_, sizeof error_), HL_OK) << error_;
  ASSERT_EQ(hl_study_next_trial(study_, &trial_, nullptr, 0, error_, sizeof error_), HL_OK);
  {
    db::Database conn(db_path_);
    conn.exec("CREATE TRIGGER refuse_chunks BEFORE INSERT ON sample_chunk "
              "BEGIN SELECT RAISE(ABORT, 'database or disk is full (test)'); END");
  }
  int rc = HL_OK;
  std::uint64_t tick = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (rc != HL_ERROR_DATABASE && std::chrono::steady_clock::now() < deadline) {
    const hl_sample s = sample_at(tick++);
    rc = hl_study_log_sample(study_, &s);
    ASSERT_TRUE(rc == HL_OK || rc == HL_STUDY_DROPPED || rc == HL_ERROR_DATABASE) << rc;
    if (tick % 1000 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_EQ(rc, HL_ERROR_DATABASE) << "the log calls never said that storage failed";
  // Nothing felt from now on would be recorded: the trial's engine was
  // halted when the writer failed, before the log call could say so.
  hl_input in{};
  in.dt_s = 0.001;
  in.insertion_m = 0.1;
  in.ve_force_N[2] = 2.0;
  hl_output out{};
  for (int k = 0; k < 400; ++k) ASSERT_EQ(hl_engine_update(trial_.engine, 0, &in, &out), HL_OK);
  EXPECT_NE(out.status & HL_HALTED, 0u);
  EXPECT_EQ(out.displayed_force_N[2], 0.0);
  EXPECT_EQ(out.insertion_force_N, 0.0);
  EXPECT_EQ(hl_study_log_event(study_, 0.001 * static_cast<double>(tick), HL_EVENT_CONTACT_START, 0, 0),
            HL_ERROR_DATABASE);
  EXPECT_EQ(hl_study_end_trial(study_, HL_TRIAL_COMPLETE, nullptr, error_, sizeof error_), HL_ERROR_DATABASE);
  EXPECT_THAT(std::string(error_), HasSubstr("disk is full (test)"));
}

// Storage that failed before any sample reached it (the writer stores the
// trial's events first): hl_study_end_trial says so and aborts the trial,
// rather than asking for samples that can no longer be kept.
TEST_F(StudyApiTest, AStorageFailureBeforeTheFirstSampleIsReportedAsOne) {
  ASSERT_EQ(hl_study_start_session(study_, "A1", nullptr, error_, sizeof error_), HL_OK) << error_;
  ASSERT_EQ(hl_study_next_trial(study_, &trial_, nullptr, 0, error_, sizeof error_), HL_OK);
  db::Database(db_path_).exec("CREATE TRIGGER refuse_events BEFORE INSERT ON event "
                              "BEGIN SELECT RAISE(ABORT, 'database or disk is full (test)'); END");
  int rc = hl_study_log_event(study_, 0.0, HL_EVENT_CONTACT_START, 0, 0);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (rc != HL_ERROR_DATABASE && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    rc = hl_study_log_event(study_, 0.0, HL_EVENT_CONTACT_END, 0, 0);
  }
  ASSERT_EQ(rc, HL_ERROR_DATABASE) << "the writer never stored the events";
  EXPECT_EQ(hl_study_end_trial(study_, HL_TRIAL_COMPLETE, nullptr, error_, sizeof error_), HL_ERROR_DATABASE);
  EXPECT_THAT(std::string(error_), HasSubstr("disk is full (test)"));
}

// A setting edited while the application's session runs: the next trial
// is refused naming it, and the session is ended as interrupted (a later
// hl_study_end_session would have recorded it closed).
TEST_F(StudyApiTest, AnEditedSettingEndsTheSessionAtTheNextTrial) {
  ASSERT_EQ(hl_study_start_session(study_, "A1", nullptr, error_, sizeof error_), HL_OK) << error_;
  ASSERT_EQ(hl_study_next_trial(study_, &trial_, nullptr, 0, error_, sizeof error_), HL_OK);
  ASSERT_EQ(complete_trial(), HL_OK) << error_;
  db::Database(db_path_).exec("UPDATE setting SET parameters_json = parameters_json || ' '");
  EXPECT_EQ(hl_study_next_trial(study_, &trial_, nullptr, 0, error_, sizeof error_), HL_ERROR_DATABASE);
  EXPECT_THAT(std::string(error_), HasSubstr("its parameters_json does not match the SHA-256 stored with it"));
  EXPECT_THAT(std::string(error_), HasSubstr("the session is ended (interrupted)"));
  EXPECT_EQ(hl_study_end_session(study_, error_, sizeof error_), HL_ERROR_STATE);
  db::OpenOptions o;
  o.integrity = db::OpenOptions::Integrity::kSkip;
  o.recover = false;
  db::StudyDb db(db_path_, o);
  for (const db::SessionRow& s : db.sessions()) EXPECT_EQ(s.status, db::SessionStatus::kInterrupted);
  int running = 0;
  for (const db::TrialRow& t : db.trials()) running += t.status == db::TrialStatus::kRunning ? 1 : 0;
  EXPECT_EQ(running, 0);
}

TEST_F(StudyApiTest, ClosingWithATrialOpenAbortsAndRequeuesIt) {
  ASSERT_EQ(hl_study_start_session(study_, "A1", nullptr, error_, sizeof error_), HL_OK) << error_;
  ASSERT_EQ(hl_study_next_trial(study_, &trial_, nullptr, 0, error_, sizeof error_), HL_OK);
  const std::int64_t id = trial_.trial_id;
  const hl_sample s = sample_at(0);
  ASSERT_EQ(hl_study_log_sample(study_, &s), HL_OK);
  hl_study_close(study_);
  study_ = nullptr;
  db::StudyDb db = open_db();
  EXPECT_EQ(db.trial(id).status, db::TrialStatus::kAborted);
  EXPECT_EQ(db.trial(id).abort_reason, "the application closed the study with the trial open");
  EXPECT_EQ(db.sample_count(id, 0), 1u);
  EXPECT_EQ(db.session(*db.trial(id).session_id).status, db::SessionStatus::kInterrupted);
  EXPECT_EQ(*db.next_planned_trial(db.trial(id).participant_id) > id, true);  // the re-queued copy is next
  EXPECT_EQ(db.trial(*db.next_planned_trial(db.trial(id).participant_id)).position, db.trial(id).position);
}

}  // namespace
}  // namespace hapticlab::sessions
