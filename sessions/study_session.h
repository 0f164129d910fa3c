#pragma once
// StudySession: the study bookkeeping of one participant's session, whoever
// runs the haptic loop — `session run` on the simulated rig
// (session_runner.h) or a lab's own application through the C study API
// (hapticlab/study.h). Both go through this class, so they keep the same
// promises:
//
//   open       database opened without recovery; the participant's
//              SessionLock taken (one live session per participant);
//              whatever a dead session left running recovered under that
//              lock; aborted trials re-queued; a session row begun
//   next_trial the planned trial earliest in the schedule
//   start_trial planned -> running; a SampleWriter drains the loop's
//              lock-free queues into the database
//   finish_trial the writer closes the trial complete or aborted (with its
//              reason and closing events); an aborted trial is re-queued
//              unless its slot reached the time limit
//   end        the session row closed (or interrupted)
//
// Storage failure: finish_trial records the trial as aborted with the
// writer's error (or leaves the reason in the lock file when even that
// write fails), closes the session as interrupted, and throws
// std::runtime_error telling the operator what to do.
//
// Threads: one thread calls everything here (not the haptic loop, which
// only pushes into the queues).

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/loop/loop_sample.h"
#include "core/loop/spsc_queue.h"
#include "core/loop/task_event.h"
#include "db/sample_writer.h"
#include "db/session_lock.h"
#include "db/study_db.h"

namespace hapticlab::sessions {

// Abort reasons with a meaning to the bookkeeping: a slot whose trial hit the
// time limit is not re-queued (running it again would most likely time out
// again); a storage failure is never recorded as a crash.
inline constexpr std::string_view kTimeLimitReason = "time limit";
inline constexpr std::string_view kStorageFailureReason = "storage failure";
inline constexpr std::string_view kOperatorStopReason = "operator stopped the session";

// "time limit (<limit>) reached before the task was complete"
std::string time_limit_reason(std::string_view limit);

// Re-queues every aborted trial of `trials` whose slot (task, setting,
// repetition, block, position) has no planned, running or complete trial
// and never reached the time limit. Idempotent, so it also heals a crash
// between aborting a trial and re-queuing it. Returns the copies added.
int requeue_aborted(db::StudyDb& db, const std::vector<db::TrialRow>& trials);

class StudySession {
 public:
  // Opens the database and begins a session of `participant` (see above).
  // `device`, `clock` and the loop's `rate_Hz` (nullopt: not known) are
  // stored with the session row. Throws
  // std::runtime_error for a missing database, a database without a study
  // or an unknown participant (listing the study's participants),
  // db::SessionBusyError when the participant has a live session elsewhere,
  // db::DbError for a database failure. `check_study`, if given, may refuse
  // the study (by throwing) before anything in the database changes.
  StudySession(const std::filesystem::path& db_path, const std::string& participant, std::string_view device,
               std::string_view clock, std::optional<double> rate_Hz,
               const std::function<void(const db::StudyRow&)>& check_study = {});
  // The same opening without the session row, for a caller that first
  // looks whether anything is left to run: a participant with nothing left
  // gets no empty session in the study. begin() adds the row; until then
  // session_id() is 0 and neither start_trial nor end may be called.
  struct DeferBegin {};
  StudySession(const std::filesystem::path& db_path, const std::string& participant, DeferBegin,
               const std::function<void(const db::StudyRow&)>& check_study = {});
  void begin(std::string_view device, std::string_view clock, std::optional<double> rate_Hz);
  bool begun() const noexcept { return session_id_ != 0; }
  // Without end() (an exception unwound the caller) the session row and a
  // running trial are left as they are, as a crash would leave them: the
  // participant's next session recovers them under the lock. Never throws.
  ~StudySession();
  StudySession(const StudySession&) = delete;
  StudySession& operator=(const StudySession&) = delete;

  db::StudyDb& db() noexcept { return db_; }
  const db::StudyRow& study() const noexcept { return study_; }
  const std::string& participant() const noexcept { return participant_; }
  std::int64_t participant_id() const noexcept { return participant_id_; }
  std::int64_t session_id() const noexcept { return session_id_; }
  // The participant's previous session, when it had died without releasing
  // its lock: who it was (and how its last trial ended, if it said so).
  const std::optional<std::string>& stale_session() const noexcept { return stale_session_; }
  int requeued_on_open() const noexcept { return requeued_on_open_; }
  // Slots in the participant's schedule, and how many are complete (this
  // and earlier sessions); per task for practice counts.
  int scheduled() const noexcept { return scheduled_; }
  int complete() const noexcept { return complete_; }
  int complete_of(const std::string& task) const;

  // The next planned trial, or nullopt when the schedule is done.
  std::optional<db::TrialRow> next_trial();
  // Marks `trial` running in this session and starts its SampleWriter on
  // the queues (which must outlive finish_trial). Throws DbError (the trial
  // is not planned) or std::logic_error (a trial is already running here).
  void start_trial(const db::TrialRow& trial, SpscQueue<LoopSample>& samples, SpscQueue<TaskEvent>& events,
                   const db::SampleWriterConfig& writer = {});
  bool trial_running() const noexcept { return writer_ != nullptr; }
  // The database failed during the trial: what the loop produces now is
  // lost, so the caller should end the trial.
  bool writer_failed() const noexcept { return writer_ && writer_->failed(); }
  // Call after the producer has stopped pushing. Stores the rest and closes
  // the trial with `outcome`; re-queues it if aborted. Returns the updates
  // (LoopSamples) stored for the trial. Throws std::runtime_error on a
  // storage failure (see above), std::logic_error without a running trial.
  std::uint64_t finish_trial(const db::TrialOutcome& outcome);
  // Stops the running trial's writer without closing the trial (it stays
  // 'running', as after a crash, for the next session's recovery). For a
  // caller unwinding before finish_trial, whose queues are about to go.
  // Never throws; does nothing without a running trial.
  void abandon_trial() noexcept;
  // Re-queued copies added by finish_trial so far.
  int requeued() const noexcept { return requeued_; }

  // While the running trial is in trouble the database cannot hear of yet
  // (a device call that does not return): `reason` goes into the lock file,
  // so that if this process is killed now, the next session's recovery
  // records it as the trial's abort reason instead of "crashed or killed".
  // clear_pending_reason() takes it back once the trial has ended by
  // itself. Never throw.
  void record_pending_reason(const std::string& reason) noexcept;
  void clear_pending_reason() noexcept;
  // Where a crash handler appends the cause of a crash (crash_note.h).
  db::SessionLock::CrashNoteTarget crash_note_target() const noexcept;

  // Closes the session row. Throws std::logic_error while a trial runs, and
  // after one was left running (abandon_trial, or a writer that could not
  // start): a session that ended over a 'running' trial is a damaged file,
  // while one left open is recovered by the participant's next session.
  void end(db::SessionStatus status = db::SessionStatus::kClosed);
  bool ended() const noexcept { return ended_; }
  // Planned trials of the participant left now.
  int trials_left();
  // Every row of this participant's trials, as the file holds them now.
  std::vector<db::TrialRow> participant_trials();

 private:
  // "N of its updates stored", or that none or an unknown number were,
  // from the file (a storage failure's message).
  std::string kept_updates_text(std::int64_t trial_id);

  std::filesystem::path db_path_;
  std::string participant_;
  db::StudyDb db_;
  db::StudyRow study_;
  std::int64_t participant_id_ = 0;
  std::optional<db::SessionLock> lock_;
  std::optional<std::string> stale_session_;
  int requeued_on_open_ = 0;
  int requeued_ = 0;
  int scheduled_ = 0;
  int complete_ = 0;
  std::map<std::string, int> complete_by_task_;
  std::int64_t session_id_ = 0;
  bool ended_ = false;
  std::optional<db::TrialRow> running_;
  std::optional<std::int64_t> left_running_;  // a trial abandoned as 'running' (see end())
  std::unique_ptr<db::SampleWriter> writer_;
};

}  // namespace hapticlab::sessions
