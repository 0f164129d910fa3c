#include "sessions/study_session.h"

#include <set>
#include <stdexcept>
#include <tuple>

namespace hapticlab::sessions {
namespace {

using Slot = std::tuple<std::string, std::int64_t, int, int, int>;  // task, setting, repetition, block, position
Slot slot_of(const db::TrialRow& t) { return {t.task, t.setting_id, t.repetition, t.block, t.position}; }

db::StudyDb open_without_recovery(const std::filesystem::path& db_path) {
  if (!std::filesystem::exists(db_path))
    throw std::runtime_error(db_path.string() + ": no such database (create it with `hapticlab study create`)");
  // Recovery waits for the participant's lock: done at open, it would take
  // a dead session's lock itself and the takeover would go unreported.
  db::OpenOptions open;
  open.recover = false;
  return db::StudyDb(db_path, open);
}

}  // namespace

std::string time_limit_reason(std::string_view limit) {
  return std::string(kTimeLimitReason) + " (" + std::string(limit) + ") reached before the task was complete";
}

// A slot that reached the time limit once is closed, whatever happened to
// it before (an earlier attempt killed or stopped by the operator) or
// after: one rule, whichever order.
int requeue_aborted(db::StudyDb& db, const std::vector<db::TrialRow>& trials) {
  std::set<Slot> covered;
  for (const db::TrialRow& t : trials)
    if (t.status != db::TrialStatus::kAborted || t.abort_reason.starts_with(kTimeLimitReason))
      covered.insert(slot_of(t));
  int added = 0;
  db::Transaction tx(db.connection());
  for (const db::TrialRow& t : trials) {
    if (t.status != db::TrialStatus::kAborted) continue;
    if (!covered.insert(slot_of(t)).second) continue;
    db.add_trial(static_cast<const db::TrialPlan&>(t));
    ++added;
  }
  tx.commit();
  return added;
}

StudySession::StudySession(const std::filesystem::path& db_path, const std::string& participant,
                           std::string_view device, std::string_view clock, std::optional<double> rate_Hz,
                           const std::function<void(const db::StudyRow&)>& check_study)
    : StudySession(db_path, participant, DeferBegin{}, check_study) {
  begin(device, clock, rate_Hz);
}

void StudySession::begin(std::string_view device, std::string_view clock, std::optional<double> rate_Hz) {
  if (begun()) throw std::logic_error("StudySession::begin(): session " + std::to_string(session_id_) +
                                      " has already begun");
  session_id_ = db_.begin_session(participant_id_, device, clock, rate_Hz);
}

StudySession::StudySession(const std::filesystem::path& db_path, const std::string& participant, DeferBegin,
                           const std::function<void(const db::StudyRow&)>& check_study)
    : db_path_(db_path), participant_(participant), db_(open_without_recovery(db_path)) {
  const std::vector<db::StudyRow> studies = db_.studies();
  if (studies.empty()) throw std::runtime_error(db_.path() + ": holds no study (run `hapticlab study create` first)");
  study_ = studies.front();
  if (check_study) check_study(study_);
  const std::optional<std::int64_t> id = db_.find_participant(study_.id, participant);
  if (!id) {
    std::set<std::string> known;
    for (const db::TrialRow& t : db_.trials(study_.id)) known.insert(t.participant_code);
    std::string codes;
    for (const std::string& c : known) codes += (codes.empty() ? " " : ", ") + c;
    throw std::runtime_error("participant: '" + participant + "' is not in study '" + study_.name +
                             "'; its participants are" + codes);
  }
  participant_id_ = *id;

  // One live session per participant (two stations may run two
  // participants on one file). Refused here, before anything changes: a
  // second session must not touch the first one's running trial.
  lock_.emplace(db::SessionLock::acquire(db_path, participant_id_, participant));
  if (lock_->stale_owner()) {
    stale_session_ = lock_->stale_owner()->describe();
    if (!lock_->stale_owner()->abort_reason.empty())
      *stale_session_ += "; its last trial ended with: " + lock_->stale_owner()->abort_reason;
  }
  // Whatever an earlier, dead session of this participant left running is
  // ours to recover now that we hold its lock (with the cause it left in
  // the lock file, if it could not store it).
  db_.recover_participant(participant_id_, lock_->stale_owner() ? lock_->stale_owner()->abort_reason : std::string());
  requeued_on_open_ = requeue_aborted(db_, participant_trials());

  std::set<Slot> slots;
  for (const db::TrialRow& t : participant_trials()) {
    slots.insert(slot_of(t));
    if (t.status == db::TrialStatus::kComplete) {
      ++complete_by_task_[t.task];
      ++complete_;
    }
  }
  scheduled_ = static_cast<int>(slots.size());
}

StudySession::~StudySession() = default;

int StudySession::complete_of(const std::string& task) const {
  const auto it = complete_by_task_.find(task);
  return it == complete_by_task_.end() ? 0 : it->second;
}

std::vector<db::TrialRow> StudySession::participant_trials() {
  std::vector<db::TrialRow> out;
  for (db::TrialRow& t : db_.trials(study_.id))
    if (t.participant_id == participant_id_) out.push_back(std::move(t));
  return out;
}

std::optional<db::TrialRow> StudySession::next_trial() {
  const std::optional<std::int64_t> next = db_.next_planned_trial(participant_id_);
  if (!next) return std::nullopt;
  return db_.trial(*next);
}

void StudySession::start_trial(const db::TrialRow& trial, SpscQueue<LoopSample>& samples,
                               SpscQueue<TaskEvent>& events, const db::SampleWriterConfig& writer) {
  if (writer_) throw std::logic_error("StudySession::start_trial(): trial " + std::to_string(running_->id) +
                                      " is still running");
  if (ended_) throw std::logic_error("StudySession::start_trial(): the session has ended");
  if (!begun()) throw std::logic_error("StudySession::start_trial(): the session has not begun");
  db_.start_trial(trial.id, session_id_);
  running_ = trial;
  try {
    writer_ = std::make_unique<db::SampleWriter>(db_path_, trial.id, samples, events, writer);
  } catch (...) {
    // The trial is 'running' in the file and nothing will finish it.
    left_running_ = trial.id;
    running_.reset();
    throw;
  }
}

std::string StudySession::kept_updates_text(std::int64_t trial_id) {
  // What the file holds, not what was handed to the writer: the commit that
  // failed may have held all of it.
  try {
    const std::uint64_t kept = db_.sample_count(trial_id, 0);
    if (kept == 0) return "none of its samples stored (the commit that failed held them)";
    return std::to_string(kept) + " of its updates stored";
  } catch (const db::DbError& e) {
    return std::string("its stored samples not counted (") + e.what() + ")";
  }
}

std::uint64_t StudySession::finish_trial(const db::TrialOutcome& outcome) {
  if (!writer_) throw std::logic_error("StudySession::finish_trial(): no trial is running");
  const db::TrialRow trial = *running_;
  std::optional<std::string> storage_failure;  // the writer's error, once the trial is over
  try {
    writer_->finish(outcome);
  } catch (const db::DbError& e) {
    storage_failure = e.what();
  }
  const std::uint64_t updates = writer_->stats().updates;
  writer_.reset();
  running_.reset();
  if (storage_failure) {
    // The trial's real end, stored if the database takes this one short
    // write, else left in the lock file for whoever recovers the trial:
    // either way it is never recorded as a crash.
    const std::string reason = std::string(kStorageFailureReason) + ": " + *storage_failure;
    bool recorded = false;
    try {
      db_.end_trial(trial.id, db::TrialStatus::kAborted, reason);
      requeued_ += requeue_aborted(db_, participant_trials());
      db_.end_session(session_id_, db::SessionStatus::kInterrupted);
      recorded = true;
    } catch (const db::DbError&) {
      lock_->record_abort_reason(reason);
    }
    ended_ = true;
    throw std::runtime_error(
        "the study database could not be written, so the session stopped: " + *storage_failure + ". Trial " +
        std::to_string(trial.id) + " was aborted with " + kept_updates_text(trial.id) +
        (recorded ? " and re-queued" : "; the reason is recorded when the session is run again") +
        ". Free disk space, then run the same command to continue.");
  }
  if (outcome.status == db::TrialStatus::kComplete) {
    ++complete_;
    ++complete_by_task_[trial.task];
  } else {
    requeued_ += requeue_aborted(db_, participant_trials());
  }
  return updates;
}

void StudySession::abandon_trial() noexcept {
  if (running_) left_running_ = running_->id;
  writer_.reset();  // its destructor commits what it has and never throws
  running_.reset();
}

void StudySession::record_pending_reason(const std::string& reason) noexcept {
  if (lock_) lock_->record_abort_reason(reason);
}

void StudySession::clear_pending_reason() noexcept {
  if (lock_) lock_->clear_abort_reason();
}

db::SessionLock::CrashNoteTarget StudySession::crash_note_target() const noexcept {
  return lock_ ? lock_->crash_note_target() : db::SessionLock::CrashNoteTarget{};
}

void StudySession::end(db::SessionStatus status) {
  if (writer_) throw std::logic_error("StudySession::end(): trial " + std::to_string(running_->id) + " is still running");
  if (ended_) throw std::logic_error("StudySession::end(): the session has already ended");
  if (!begun()) throw std::logic_error("StudySession::end(): the session has not begun");
  if (left_running_)
    throw std::logic_error("StudySession::end(): trial " + std::to_string(*left_running_) +
                           " was left running; the session stays open for the participant's next session to "
                           "recover");
  db_.end_session(session_id_, status);
  ended_ = true;
}

int StudySession::trials_left() {
  int left = 0;
  for (const db::TrialRow& t : participant_trials())
    if (t.status == db::TrialStatus::kPlanned) ++left;
  return left;
}

}  // namespace hapticlab::sessions
