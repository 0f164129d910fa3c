#include "sessions/session_runner.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <map>
#include <set>
#include <thread>
#include <tuple>

#include <gtest/gtest.h>

#include "core/loop/spsc_queue.h"
#include "sessions/study_session.h"
#include "tests/sessions/session_fixture.h"

namespace hapticlab::sessions {
namespace {

using testing::SessionFixture;
using db::TrialStatus;

std::vector<db::TrialRow> trials_of_open(db::StudyDb& db, const std::string& code) {
  std::vector<db::TrialRow> out;
  for (auto& t : db.trials())
    if (t.participant_code == code) out.push_back(t);
  return out;
}

std::vector<db::TrialRow> trials_of(const std::filesystem::path& path, const std::string& code) {
  db::OpenOptions open;
  open.recover = false;
  db::StudyDb db(path, open);
  return trials_of_open(db, code);
}

int count(const std::vector<db::TrialRow>& trials, TrialStatus status) {
  int n = 0;
  for (const auto& t : trials) n += t.status == status ? 1 : 0;
  return n;
}

using testing::options_for;

TEST_F(SessionFixture, RunsTheScheduleInOrderAndLogsEverySample) {
  const SessionResult r = run_session(db_path_, options_for("A1"));
  EXPECT_EQ(r.trials_run, 4);
  EXPECT_EQ(r.trials_complete, 4);
  EXPECT_EQ(r.trials_left, 0);
  EXPECT_FALSE(r.stopped_by_operator);
  const auto trials = trials_of(db_path_, "A1");
  ASSERT_EQ(trials.size(), 4u);
  db::OpenOptions open;
  open.recover = false;
  db::StudyDb db(db_path_, open);
  std::uint64_t stored = 0;
  double last_start = 0.0;
  for (const auto& t : trials) {  // schedule order
    EXPECT_EQ(t.status, TrialStatus::kComplete);
    ASSERT_TRUE(t.started_unix_s && t.ended_unix_s);
    EXPECT_GE(*t.started_unix_s, last_start);
    last_start = *t.started_unix_s;
    const std::uint64_t n = db.sample_count(t.id, 0);
    EXPECT_EQ(n, db.sample_count(t.id, 1));
    EXPECT_GT(n, 1000u);  // a dissection takes seconds at 1 kHz
    stored += n;
    const auto timing = db.loop_timing(t.id);
    ASSERT_TRUE(timing && timing->timing);
    EXPECT_EQ(timing->dropped_samples, 0u);
    bool complete_event = false;
    for (const auto& e : db.events(t.id)) complete_event |= e.type == "task_complete";
    EXPECT_TRUE(complete_event);
  }
  EXPECT_EQ(stored, r.samples_logged);
  // The other participant is untouched.
  EXPECT_EQ(count(trials_of(db_path_, "B2"), TrialStatus::kPlanned), 4);
}

TEST_F(SessionFixture, ResumesWithTheNextUnfinishedTrialAndNeverRepeatsACompleteOne) {
  SessionOptions o = options_for("A1");
  o.max_trials = 1;
  EXPECT_EQ(run_session(db_path_, o).trials_complete, 1);
  o.max_trials = 2;
  const SessionResult second = run_session(db_path_, o);
  EXPECT_EQ(second.trials_complete, 2);
  EXPECT_EQ(second.trials_left, 1);
  o.max_trials.reset();
  EXPECT_EQ(run_session(db_path_, o).trials_run, 1);
  EXPECT_EQ(run_session(db_path_, o).trials_run, 0);  // nothing left: nothing runs again
  const auto trials = trials_of(db_path_, "A1");
  EXPECT_EQ(trials.size(), 4u);
  EXPECT_EQ(count(trials, TrialStatus::kComplete), 4);
}

TEST_F(SessionFixture, SameDatabaseSameSimulatedResults) {
  // Two copies of the fresh study run separately give identical samples.
  const auto copy = dir_ / "copy.db";
  std::filesystem::copy_file(db_path_, copy);
  SessionOptions o = options_for("B2");
  o.max_trials = 1;
  run_session(db_path_, o);
  run_session(copy, o);
  db::OpenOptions open;
  open.recover = false;
  db::StudyDb a(db_path_, open), b(copy, open);
  const auto ta = trials_of(db_path_, "B2"), tb = trials_of(copy, "B2");
  ASSERT_EQ(ta[0].id, tb[0].id);
  const auto sa = a.samples(ta[0].id, 1), sb = b.samples(tb[0].id, 1);
  ASSERT_EQ(sa.size(), sb.size());
  ASSERT_FALSE(sa.empty());
  for (std::size_t k = 0; k < sa.size(); ++k) {
    ASSERT_EQ(sa[k].t_s, sb[k].t_s) << k;
    ASSERT_EQ(sa[k].value.tip_position_m, sb[k].value.tip_position_m) << k;
    ASSERT_EQ(sa[k].value.ve_force_N, sb[k].value.ve_force_N) << k;
  }
}

TEST_F(SessionFixture, TrainingIsRecordedButNotScheduled) {
  SessionOptions o;
  o.participant = "B2";  // the protocol gives B2 two training trials
  o.max_trials = 1;
  const SessionResult r = run_session(db_path_, o);
  EXPECT_EQ(r.training_trials, 2);
  db::StudyDb db(db_path_);
  const auto training = db.training(r.session_id);
  ASSERT_EQ(training.size(), 1u);
  EXPECT_EQ(training[0].task, "dissection");
  EXPECT_EQ(training[0].trials, 2);
  ASSERT_TRUE(training[0].duration_s);
  EXPECT_GT(*training[0].duration_s, 1.0);  // simulated seconds actually trained
  EXPECT_EQ(trials_of(db_path_, "B2").size(), 4u);
}

// Training the operator ends: trials repeat until the counter moves on from
// its value when the training started, checked after each trial; the
// training_trials cap still holds.
TEST_F(SessionFixture, OperatorEndsTrainingAfterTheCurrentTrial) {
  std::atomic<int> ends{7};  // pressed before: not an end of this training
  SessionOptions o = options_for("A1");
  o.training_trials = 3;
  o.training_ends = &ends;
  o.max_trials = 1;
  const SessionResult capped = run_session(db_path_, o);
  EXPECT_EQ(capped.training_trials, 3);

  // A press while the first training trial is about to run (on_progress
  // reports the training just before it): training ends after that trial.
  o.on_progress = [&](const SessionProgress& p) {
    if (p.phase == SessionProgress::Phase::kTraining) ends.fetch_add(1);
  };
  const SessionResult ended = run_session(db_path_, o);
  EXPECT_EQ(ended.training_trials, 1);
  EXPECT_EQ(ended.trials_complete, 1);
  db::StudyDb db(db_path_);
  const auto training = db.training(ended.session_id);
  ASSERT_EQ(training.size(), 1u);
  EXPECT_EQ(training[0].trials, 1);
}

// An abort the console accepted as the session's last trial ended, after
// the runner's last poll of the trial: recorded on that trial as missed
// (the trial stays complete), as one reaching the next trial is; it was
// dropped before.
TEST_F(SessionFixture, AnAbortThatArrivesAsTheLastTrialEndsIsRecordedAsMissed) {
  SessionOptions o = options_for("A1");
  o.max_trials = 1;
  std::vector<OperatorEvent> pending;
  std::int64_t finished = 0;
  o.on_progress = [&](const SessionProgress& p) {
    if (p.phase != SessionProgress::Phase::kTrialFinished) return;
    finished = p.trial_id;
    pending.push_back({"operator_abort", "too late", true, p.trial_id});
  };
  o.take_operator_events = [&](std::vector<OperatorEvent>& out) {
    out.insert(out.end(), pending.begin(), pending.end());
    pending.clear();
  };
  const SessionResult r = run_session(db_path_, o);
  EXPECT_EQ(r.trials_complete, 1);
  ASSERT_NE(finished, 0);
  db::OpenOptions open;
  open.recover = false;
  db::StudyDb db(db_path_, open);
  EXPECT_EQ(db.trial(finished).status, TrialStatus::kComplete);
  const auto events = db.events(finished);
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.back().type, "operator_abort_missed");
  EXPECT_EQ(events.back().detail, "trial " + std::to_string(finished) + " had ended: too late");
  EXPECT_GT(events.back().t_s, 1.0);  // at the trial's end
}

TEST_F(SessionFixture, OperatorStopAbortsKeepsSamplesAndRequeues) {
  std::atomic<bool> stop{false};
  SessionOptions o = options_for("A1");
  o.clock = ClockKind::kWall;  // so the trial is still running when the stop comes
  o.stop = &stop;
  std::thread stopper([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(400));
    stop = true;
  });
  const SessionResult r = run_session(db_path_, o);
  stopper.join();
  EXPECT_TRUE(r.stopped_by_operator);
  EXPECT_EQ(r.trials_run, 1);
  EXPECT_EQ(r.trials_aborted, 1);
  EXPECT_EQ(r.trials_requeued, 1);
  const auto trials = trials_of(db_path_, "A1");
  ASSERT_EQ(trials.size(), 5u);
  const auto& aborted = trials[0];
  EXPECT_EQ(aborted.status, TrialStatus::kAborted);
  EXPECT_EQ(aborted.abort_reason, "operator stopped the session");
  EXPECT_EQ(trials[1].status, TrialStatus::kPlanned);
  EXPECT_EQ(trials[1].position, aborted.position);  // the copy keeps its place
  EXPECT_EQ(trials[1].setting_id, aborted.setting_id);
  db::OpenOptions open;
  open.recover = false;
  db::StudyDb db(db_path_, open);
  EXPECT_GT(db.sample_count(aborted.id, 0), 100u);  // ~0.4 s at 1 kHz, kept
  const auto events = db.events(aborted.id);
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.back().type, "operator_abort");
  EXPECT_EQ(events.back().instrument, -1);
  EXPECT_GE(events.back().t_s, 0.1);  // after the 100+ samples above

  // Running again starts with the re-queued copy.
  SessionOptions again = options_for("A1");
  again.max_trials = 1;
  run_session(db_path_, again);
  EXPECT_EQ(trials_of(db_path_, "A1")[1].status, TrialStatus::kComplete);
}

// The console's controls: a note and an abort with a typed reason during
// the first trial (the runner's 3rd poll of the actions, so the loop is
// running), a pause before the second. The aborted trial is re-queued, the
// session goes on, and both actions are events of the trial with a time.
TEST_F(SessionFixture, OperatorAbortWithAReasonRequeuesAndTheSessionGoesOn) {
  SessionOptions o = options_for("A1");
  o.max_trials = 2;
  int polls = 0;
  o.take_operator_events = [&](std::vector<OperatorEvent>& out) {
    if (++polls == 3) {
      out.push_back({"operator_note", "chair adjusted", false});
      out.push_back({"operator_abort", "participant sneezed", true});
    }
  };
  int holds = 0;
  o.hold_before_trial = [&] { return ++holds == 2 || holds == 3; };  // paused twice before the 2nd trial
  const SessionResult r = run_session(db_path_, o);
  EXPECT_FALSE(r.stopped_by_operator);
  EXPECT_EQ(r.trials_run, 2);
  EXPECT_EQ(r.trials_aborted, 1);
  EXPECT_EQ(r.trials_complete, 1);
  EXPECT_EQ(holds, 4);  // 1st trial: 1 call; 2nd: held twice, then let go
  const auto trials = trials_of(db_path_, "A1");
  ASSERT_EQ(trials.size(), 5u);
  EXPECT_EQ(trials[0].status, TrialStatus::kAborted);
  EXPECT_EQ(trials[0].abort_reason, "operator abort: participant sneezed");
  // The re-queued copy, at the same place, is the next trial and completes.
  EXPECT_EQ(trials[1].position, trials[0].position);
  EXPECT_EQ(trials[1].status, TrialStatus::kComplete);
  db::OpenOptions open;
  open.recover = false;
  db::StudyDb db(db_path_, open);
  std::vector<std::pair<std::string, std::string>> actions;
  for (const auto& e : db.events(trials[0].id))
    if (e.type.starts_with("operator_")) {
      actions.emplace_back(e.type, e.detail);
      EXPECT_GE(e.t_s, 0.0);
    }
  EXPECT_EQ(actions, (std::vector<std::pair<std::string, std::string>>{{"operator_note", "chair adjusted"},
                                                                      {"operator_abort", "participant sneezed"}}));
}

// An abort names the trial the operator saw. During that trial it aborts
// it; taken once another trial runs (the first ended while the reason was
// typed), it aborts nothing and is logged with the running trial as
// missed, naming the trial it was for.
TEST_F(SessionFixture, AnAbortForATrialThatHasEndedDoesNotAbortTheNext) {
  SessionOptions o = options_for("A1");
  o.max_trials = 2;
  std::int64_t running = 0, first = 0;
  o.on_progress = [&](const SessionProgress& p) {
    if (p.phase == SessionProgress::Phase::kTrialStarted) running = p.trial_id;
  };
  int polls = 0;
  bool stale_sent = false;
  o.take_operator_events = [&](std::vector<OperatorEvent>& out) {
    if (running == 0) return;  // training, before the first trial
    if (first == 0) first = running;
    if (running == first && ++polls == 3) out.push_back({"operator_abort", "meant for this one", true, first});
    if (running != first && !stale_sent) {
      out.push_back({"operator_abort", "meant for the first", true, first});
      stale_sent = true;
    }
  };
  const SessionResult r = run_session(db_path_, o);
  EXPECT_EQ(r.trials_aborted, 1);
  EXPECT_EQ(r.trials_complete, 1);
  ASSERT_TRUE(stale_sent);
  const auto trials = trials_of(db_path_, "A1");
  ASSERT_GE(trials.size(), 2u);
  EXPECT_EQ(trials[0].id, first);
  EXPECT_EQ(trials[0].abort_reason, "operator abort: meant for this one");
  EXPECT_EQ(trials[1].status, TrialStatus::kComplete);
  db::OpenOptions open;
  open.recover = false;
  db::StudyDb db(db_path_, open);
  std::vector<std::pair<std::string, std::string>> actions;
  for (const auto& e : db.events(trials[1].id))
    if (e.type.starts_with("operator_")) actions.emplace_back(e.type, e.detail);
  EXPECT_EQ(actions, (std::vector<std::pair<std::string, std::string>>{
                         {"operator_abort_missed", "trial " + std::to_string(first) + " had ended: meant for the first"}}));
}

TEST_F(SessionFixture, DeviceFaultAbortsTheTrialAndEndsTheSession) {
  SessionOptions o = options_for("A1");
  int configured = 0;
  o.configure_trial = [&](SimTrialConfig& c, const db::TrialRow&) {
    if (++configured == 2) c.inject_fault = std::make_pair(DeviceStatus::kReadFailed, 0.5);
  };
  const SessionResult r = run_session(db_path_, o);
  EXPECT_TRUE(r.device_fault);
  EXPECT_NE(r.device_fault_reason.find("device fault"), std::string::npos) << r.device_fault_reason;
  EXPECT_EQ(r.trials_complete, 1);
  EXPECT_EQ(r.trials_aborted, 1);
  const auto trials = trials_of(db_path_, "A1");
  EXPECT_EQ(count(trials, TrialStatus::kAborted), 1);
  EXPECT_EQ(count(trials, TrialStatus::kPlanned), 3);  // the faulted one re-queued
  db::StudyDb db(db_path_);
  EXPECT_EQ(db.session(r.session_id).status, db::SessionStatus::kInterrupted);
}

// A setting edited with an SQLite shell while a session runs (the runner
// has the file open, so its checks at open have passed) was what the next
// trial's engine was configured with. The next trial is refused before it
// starts, naming the setting; nothing of it is recorded.
TEST_F(SessionFixture, ASettingEditedDuringTheSessionStopsItBeforeTheNextTrial) {
  SessionOptions o = options_for("A1");
  std::int64_t finished = 0;
  o.on_progress = [&](const SessionProgress& p) {
    if (p.phase != SessionProgress::Phase::kTrialFinished || finished != 0) return;
    finished = p.trial_id;
    // One space more: the same parameters to a JSON parser, another text.
    db::Database(db_path_).exec("UPDATE setting SET parameters_json = parameters_json || ' '");
  };
  try {
    run_session(db_path_, o);
    ADD_FAILURE() << "the session ran on with edited settings";
  } catch (const db::DbError& e) {
    EXPECT_NE(std::string(e.what()).find("its parameters_json does not match the SHA-256 stored with it"),
              std::string::npos)
        << e.what();
  }
  ASSERT_NE(finished, 0);
  db::OpenOptions open;
  open.recover = false;
  open.integrity = db::OpenOptions::Integrity::kSkip;  // the file is refused otherwise, as it should be
  db::StudyDb db(db_path_, open);
  const auto trials = trials_of_open(db, "A1");
  EXPECT_EQ(db.trial(finished).status, TrialStatus::kComplete);
  EXPECT_EQ(count(trials, TrialStatus::kComplete), 1);
  EXPECT_EQ(count(trials, TrialStatus::kRunning), 0);
  EXPECT_EQ(count(trials, TrialStatus::kAborted), 0);
  for (const db::SessionRow& s : db.sessions()) EXPECT_EQ(s.status, db::SessionStatus::kInterrupted);
}

// The same edit met by the session's training, which reads the study's
// control setting: the session ends interrupted too, not left open.
TEST_F(SessionFixture, ASettingEditedBeforeTheTrainingStopsTheSessionInterrupted) {
  SessionOptions o = options_for("A1");
  o.training_trials = 1;
  bool edited = false;
  o.on_progress = [&](const SessionProgress& p) {
    if (p.phase != SessionProgress::Phase::kTraining || edited) return;
    edited = true;
    db::Database(db_path_).exec("UPDATE setting SET parameters_json = parameters_json || ' '");
  };
  EXPECT_THROW(run_session(db_path_, o), db::DbError);
  ASSERT_TRUE(edited);
  db::OpenOptions open;
  open.recover = false;
  open.integrity = db::OpenOptions::Integrity::kSkip;
  db::StudyDb db(db_path_, open);
  EXPECT_EQ(count(trials_of_open(db, "A1"), TrialStatus::kPlanned), static_cast<int>(trials_of_open(db, "A1").size()));
  const std::vector<db::SessionRow> sessions = db.sessions();
  ASSERT_EQ(sessions.size(), 1u);
  EXPECT_EQ(sessions[0].status, db::SessionStatus::kInterrupted);
}

// A trial left 'running' (its writer could not start, or a caller unwound
// past it) keeps its session open: ended over a running trial, the file
// would hold a running trial in an ended session, which every reader
// refuses as damage, the participant's next session included. Left open,
// that session recovers it.
TEST_F(SessionFixture, ASessionOverATrialLeftRunningStaysOpenAndIsRecovered) {
  std::int64_t left = 0;
  {
    StudySession session(db_path_, "A1", "sim", "virtual", 1000.0);
    const std::optional<db::TrialRow> next = session.next_trial();
    ASSERT_TRUE(next.has_value());
    left = next->id;
    SpscQueue<LoopSample> samples(16);
    SpscQueue<TaskEvent> events(16);
    db::SampleWriterConfig broken;
    broken.commit_interval = std::chrono::milliseconds(0);  // the writer refuses to start
    EXPECT_THROW(session.start_trial(*next, samples, events, broken), std::invalid_argument);
    EXPECT_THROW(session.end(db::SessionStatus::kInterrupted), std::logic_error);
  }
  SessionOptions o = options_for("A1");
  o.max_trials = 1;
  const SessionResult r = run_session(db_path_, o);
  EXPECT_EQ(r.trials_complete, 1);
  db::StudyDb db(db_path_);  // every check at open: no running trial in an ended session
  EXPECT_EQ(db.trial(left).status, TrialStatus::kAborted);
  const std::vector<db::SessionRow> sessions = db.sessions();
  ASSERT_EQ(sessions.size(), 2u);
  EXPECT_EQ(sessions[0].status, db::SessionStatus::kInterrupted);
  EXPECT_EQ(sessions[1].status, db::SessionStatus::kClosed);
}

TEST_F(SessionFixture, KilledRunnerResumesAfterReopening) {
  // The runner dies (SIGKILL) in the middle of a wall-clock trial.
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    SessionOptions o = options_for("A1");
    o.clock = ClockKind::kWall;
    try {
      run_session(db_path_, o);
    } catch (...) {
    }
    _exit(0);
  }
  // Killed once a trial is running and some of its samples are on disk
  // (polled, not a fixed sleep: on a loaded machine the child may take
  // longer to get there).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  for (bool ready = false; !ready && std::chrono::steady_clock::now() < deadline;) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    try {
      db::OpenOptions open;
      open.recover = false;
      open.integrity = db::OpenOptions::Integrity::kSkip;
      db::StudyDb db(db_path_, open);
      for (const auto& t : trials_of(db_path_, "A1"))
        if (t.status == TrialStatus::kRunning && db.sample_count(t.id, 1) > 0) ready = true;
    } catch (const db::DbError&) {
      // the child may be creating the schema; try again
    }
  }
  kill(child, SIGKILL);
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status));

  {
    const auto trials = trials_of(db_path_, "A1");  // opened without recovery
    ASSERT_EQ(count(trials, TrialStatus::kRunning), 1);
  }
  SessionOptions o = options_for("A1");
  const SessionResult r = run_session(db_path_, o);  // recovers, re-queues, finishes
  EXPECT_EQ(r.trials_requeued, 1);
  EXPECT_EQ(r.trials_left, 0);
  const auto trials = trials_of(db_path_, "A1");
  EXPECT_EQ(count(trials, TrialStatus::kComplete), 4);
  EXPECT_EQ(count(trials, TrialStatus::kAborted), 1);
  for (const auto& t : trials)
    if (t.status == TrialStatus::kAborted) {
      EXPECT_EQ(t.abort_reason, db::kInterruptedReason);
      db::OpenOptions open;
      open.recover = false;
      db::StudyDb db(db_path_, open);
      EXPECT_GT(db.sample_count(t.id, 1), 0u);  // what reached the disk is kept
    }
}

// One rule for the time limit, whatever happened to the slot before: a
// slot that reached it is not re-queued. Before, a slot whose earlier
// attempt had been killed was re-queued after timing out (the killed
// attempt, aborted but not by the limit, re-queued it), and one that had
// not was not.
TEST_F(SessionFixture, ATimedOutSlotIsNotRequeuedEvenIfAnEarlierAttemptWasKilled) {
  std::int64_t killed = 0;
  {
    // What a runner killed mid-trial leaves, made directly.
    db::OpenOptions open;
    open.recover = false;
    db::StudyDb db(db_path_, open);
    const std::int64_t participant = *db.find_participant(db.studies().front().id, "A1");
    killed = *db.next_planned_trial(participant);
    db.start_trial(killed, db.begin_session(participant, "sim", "virtual", 1000.0));
  }
  SessionOptions o = options_for("A1");
  o.max_trial_s = 0.05;  // no simulated surgeon finishes a dissection in 50 ms
  o.max_trials = 1;
  const SessionResult r = run_session(db_path_, o);
  EXPECT_EQ(r.trials_run, 1);
  EXPECT_EQ(r.trials_aborted, 1);
  const auto trials = trials_of(db_path_, "A1");
  const db::TrialRow* first = nullptr;
  for (const auto& t : trials)
    if (t.id == killed) first = &t;
  ASSERT_NE(first, nullptr);
  EXPECT_EQ(first->abort_reason, db::kInterruptedReason);
  int at_slot = 0, timed_out = 0, planned_at_slot = 0;
  for (const auto& t : trials) {
    if (t.position != first->position) continue;
    ++at_slot;
    if (t.abort_reason.starts_with("time limit")) {
      ++timed_out;
      // The limit as the operator gave it, not "0.050000 s".
      EXPECT_EQ(t.abort_reason, "time limit (0.05 s) reached before the task was complete");
    }
    if (t.status == TrialStatus::kPlanned) ++planned_at_slot;
  }
  EXPECT_EQ(at_slot, 2) << "the killed attempt and its timed-out re-run";
  EXPECT_EQ(timed_out, 1);
  EXPECT_EQ(planned_at_slot, 0) << "a timed-out slot is closed";
  // Running again goes on with the next slot, not the timed-out one.
  const SessionResult again = run_session(db_path_, o);
  EXPECT_EQ(again.trials_requeued, 0);
}

TEST_F(SessionFixture, BadOptionsAndUnknownParticipantsAreNamed) {
  SessionOptions o = options_for("ZZ");
  try {
    run_session(db_path_, o);
    FAIL() << "unknown participant accepted";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("'ZZ'"), std::string::npos) << what;
    EXPECT_NE(what.find("A1, B2"), std::string::npos) << what;
  }
  o = options_for("A1");
  o.rate_Hz = 5000.0;
  EXPECT_THROW(run_session(db_path_, o), std::invalid_argument);
  o = options_for("A1");
  o.device.options["gain"] = "2";  // the sim device takes no options
  EXPECT_THROW(run_session(db_path_, o), std::invalid_argument);
  EXPECT_THROW(parse_device_spec("lsw"), std::invalid_argument);
  EXPECT_THROW(run_session(dir_ / "missing.db", options_for("A1")), std::runtime_error);
  EXPECT_FALSE(std::filesystem::exists(dir_ / "missing.db"));
}

// Issue 15: a study whose tasks are the lab's own (an external VE) cannot
// run on the simulated rig; it is refused before the session begins.
TEST_F(SessionFixture, AStudyWithAnExternalVeIsRefusedBeforeAnythingChanges) {
  const std::filesystem::path settings = testing::source_dir() / "examples" / "settings";
  const std::filesystem::path protocol = dir_ / "external.json";
  std::ofstream(protocol) << R"({"study": "lab task", "ve": "external", "tasks": ["peg touch"],
      "repetitions": {"peg touch": 1}, "settings": [")" << (settings / "high_fidelity.json").string()
                          << R"(", ")" << (settings / "no_force_feedback.json").string() << R"("],
      "participants": ["P1"], "design": {"type": "complete"}, "seed": 3})";
  const std::filesystem::path path = dir_ / "external.db";
  {
    db::StudyDb db(path);
    create_study(db, protocol, "test");
  }
  try {
    run_session(path, options_for("P1"));
    FAIL() << "an external-VE study ran on the simulated rig";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("\"ve\": \"external\""), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("hapticlab/study.h"), std::string::npos) << e.what();
  }
  db::StudyDb db(path);
  EXPECT_EQ(count(trials_of(path, "P1"), TrialStatus::kPlanned), 2);
  db::Statement sessions = db.connection().prepare("SELECT COUNT(*) FROM session");
  ASSERT_TRUE(sessions.step());
  EXPECT_EQ(sessions.column_int64(0), 0);
}

TEST(SessionSeeds, DifferPerParticipantAndTrialAndAreStable) {
  EXPECT_EQ(participant_seed(2004, "S1"), participant_seed(2004, "S1"));
  EXPECT_NE(participant_seed(2004, "S1"), participant_seed(2004, "S2"));
  EXPECT_NE(participant_seed(2004, "S1"), participant_seed(2005, "S1"));
  EXPECT_NE(trial_seed(1, 1), trial_seed(1, 2));
}

}  // namespace
}  // namespace hapticlab::sessions
