#include "sessions/session_runner.h"

#include <chrono>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>
#include <thread>
#include <tuple>

#include <nlohmann/json.hpp>

#include "core/common/random.h"
#include "core/device/device_factory.h"
#include "core/sim/task_event.h"
#include "db/session_lock.h"
#include "protocols/rng.h"

namespace hapticlab::sessions {
namespace {

constexpr const char* kTimeLimitReason = "time limit";
constexpr const char* kStorageFailureReason = "storage failure";

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

bool stop_requested(const SessionOptions& options) {
  return options.stop != nullptr && options.stop->load(std::memory_order_relaxed);
}

void check_options(const SessionOptions& options) {
  if (options.participant.empty()) throw std::invalid_argument("participant: a participant code is required");
  if (!(options.rate_Hz >= 150.0 && options.rate_Hz <= 2000.0))
    throw std::invalid_argument("rate_Hz: " + std::to_string(options.rate_Hz) + " is outside 150..2000 Hz");
  if (!(options.max_trial_s > 0.0) || !std::isfinite(options.max_trial_s))
    throw std::invalid_argument("max_trial_s: " + std::to_string(options.max_trial_s) +
                                " must be a positive number of seconds");
  if (options.training_trials && (*options.training_trials < 0 || *options.training_trials > 1000))
    throw std::invalid_argument("training_trials: " + std::to_string(*options.training_trials) +
                                " is outside 0..1000");
  if (options.max_trials && *options.max_trials < 0)
    throw std::invalid_argument("max_trials: " + std::to_string(*options.max_trials) + " must be >= 0");
}

// The protocol's training trials for `code`: the participant entry's
// training_trials, else the top-level one, else 0. The stored protocol was
// validated when the study was created, so only the shape is read here.
int protocol_training_trials(const std::string& protocol_json, const std::string& code) {
  const nlohmann::json j = nlohmann::json::parse(protocol_json);
  int trials = j.value("training_trials", 0);
  for (const nlohmann::json& p : j.at("participants")) {
    if (p.is_object() && p.value("code", std::string()) == code) trials = p.value("training_trials", trials);
  }
  return trials;
}

// The setting simulated participants train under: the protocol's first
// (the control, High Fidelity in the thesis).
std::int64_t training_setting_id(db::StudyDb& db, std::int64_t study_id) {
  db::Statement q = db.connection().prepare("SELECT id FROM setting WHERE study_id = ? ORDER BY id LIMIT 1");
  q.bind(1, study_id);
  if (!q.step()) throw std::runtime_error(db.path() + ": the study has no settings");
  return q.column_int64(0);
}

using Slot = std::tuple<std::string, std::int64_t, int, int, int>;  // task, setting, repetition, block, position
Slot slot_of(const db::TrialRow& t) { return {t.task, t.setting_id, t.repetition, t.block, t.position}; }

std::vector<db::TrialRow> participant_trials(db::StudyDb& db, std::int64_t study_id, std::int64_t participant_id) {
  std::vector<db::TrialRow> out;
  for (db::TrialRow& t : db.trials(study_id))
    if (t.participant_id == participant_id) out.push_back(std::move(t));
  return out;
}

// Re-queues every aborted trial whose slot has no planned, running or
// complete trial: idempotent, so it also heals a crash between aborting a
// trial and re-queuing it. A slot that reached the time limit once is
// closed, whatever happened to it before (an earlier attempt killed or
// stopped by the operator) or after: one rule, whichever order.
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

}  // namespace

std::uint64_t participant_seed(std::uint64_t study_seed, std::string_view code) noexcept {
  Random r = Random::derive(study_seed, protocols::fnv1a64(code));
  return r.next_u64();
}

std::uint64_t trial_seed(std::uint64_t participant_seed, std::int64_t trial_id) noexcept {
  Random r = Random::derive(participant_seed, static_cast<std::uint64_t>(trial_id));
  return r.next_u64();
}

SessionResult run_session(const std::filesystem::path& db_path, const SessionOptions& options) {
  check_options(options);
  // The device is opened (a plugin loaded, a socket bound) and dropped
  // once before anything is stored, so a wrong path, option or port is
  // refused with nothing changed. Each trial opens it again.
  (void)open_device(options.device);
  if (!std::filesystem::exists(db_path))
    throw std::runtime_error(db_path.string() + ": no such database (create it with `hapticlab study create`)");
  // Recovery waits for the participant's lock (below): done at open, it
  // would take a dead session's lock itself and the takeover would go
  // unreported.
  db::OpenOptions open;
  open.recover = false;
  db::StudyDb db(db_path, open);
  const std::vector<db::StudyRow> studies = db.studies();
  if (studies.empty()) throw std::runtime_error(db.path() + ": holds no study (run `hapticlab study create` first)");
  const db::StudyRow& study = studies.front();
  const std::optional<std::int64_t> participant_id = db.find_participant(study.id, options.participant);
  if (!participant_id) {
    std::set<std::string> known;
    for (const db::TrialRow& t : db.trials(study.id)) known.insert(t.participant_code);
    std::string codes;
    for (const std::string& c : known) codes += (codes.empty() ? " " : ", ") + c;
    throw std::runtime_error("participant: '" + options.participant + "' is not in study '" + study.name +
                             "'; its participants are" + codes);
  }

  // One live session per participant (two stations may run two
  // participants on one file). Refused here, before anything changes: a
  // second session must not touch the first one's running trial.
  db::SessionLock lock = db::SessionLock::acquire(db_path, *participant_id, options.participant);
  SessionResult result;
  if (lock.stale_owner()) {
    result.stale_session = lock.stale_owner()->describe();
    if (!lock.stale_owner()->abort_reason.empty())
      *result.stale_session += "; its last trial ended with: " + lock.stale_owner()->abort_reason;
  }
  // Whatever an earlier, dead session of this participant left running is
  // ours to recover now that we hold its lock (with the cause it left in
  // the lock file, if it could not store it).
  db.recover_participant(*participant_id,
                         lock.stale_owner() ? lock.stale_owner()->abort_reason : std::string());
  result.trials_requeued = requeue_aborted(db, participant_trials(db, study.id, *participant_id));

  const std::uint64_t who = participant_seed(study.seed, options.participant);
  const int training_per_task =
      options.training_trials.value_or(protocol_training_trials(study.protocol_json, options.participant));
  const std::int64_t training_setting = training_setting_id(db, study.id);
  std::map<std::string, int> complete_by_task;  // practice so far
  int scheduled = 0, complete = 0;
  {
    std::set<Slot> slots;
    for (const db::TrialRow& t : participant_trials(db, study.id, *participant_id)) {
      slots.insert(slot_of(t));
      if (t.status == db::TrialStatus::kComplete) {
        ++complete_by_task[t.task];
        ++complete;
      }
    }
    scheduled = static_cast<int>(slots.size());
  }

  result.session_id =
      db.begin_session(*participant_id, options.device.describe(), options.clock == ClockKind::kVirtual ? "virtual" : "wall");
  const Clock::time_point session_start = Clock::now();
  std::set<std::string> trained;
  double trial_wall_s = 0.0;  // wall time of trials finished in this session
  int trials_timed = 0;

  auto progress = [&](SessionProgress p) {
    if (!options.on_progress) return;
    p.participant = options.participant;
    p.trial_count = scheduled;
    p.elapsed_s = seconds_since(session_start);
    if (trials_timed > 0) {
      p.eta_s = trial_wall_s / trials_timed * std::max(0, scheduled - complete);
    }
    options.on_progress(p);
  };

  auto base_config = [&](const std::string& task, const NamedSettings& settings, std::uint64_t seed, int practice) {
    SimTrialConfig c;
    c.task = parse_task_kind(task);
    c.device = options.device;
    c.settings = settings.engine;
    c.participant_seed = who;
    c.trial_seed = seed;
    c.practice_trials = practice;
    c.clock = options.clock;
    c.rate_Hz = options.rate_Hz;
    c.max_duration_s = options.max_trial_s;
    return c;
  };

  while (!stop_requested(options)) {
    if (options.max_trials && result.trials_run >= *options.max_trials) break;
    const std::optional<std::int64_t> next = db.next_planned_trial(*participant_id);
    if (!next) break;
    const db::TrialRow trial = db.trial(*next);

    // Training: before this session's first trial of a task. Unlogged
    // sample by sample (it is not analysed); its length and count are kept.
    if (training_per_task > 0 && trained.insert(trial.task).second) {
      // Taken before the training is announced, so an end the operator
      // gives as soon as it shows counts.
      const int ends_before =
          options.training_ends != nullptr ? options.training_ends->load(std::memory_order_acquire) : 0;
      SessionProgress p;
      p.phase = SessionProgress::Phase::kTraining;
      p.trial_number = complete + 1;
      p.task = trial.task;
      progress(p);
      const NamedSettings control = db.setting(training_setting);
      db::TrainingRow row;
      row.session_id = result.session_id;
      row.task = trial.task;
      row.started_unix_s = db::unix_now_s();
      double trained_s = 0.0;
      int done = 0;
      const auto operator_ended = [&] {
        return options.training_ends != nullptr &&
               options.training_ends->load(std::memory_order_acquire) != ends_before;
      };
      for (int k = 0; k < training_per_task && !stop_requested(options) && !(k > 0 && operator_ended()); ++k) {
        SimTrialConfig c = base_config(trial.task, control,
                                       Random::derive(who, protocols::fnv1a64("training:" + trial.task)).next_u64() +
                                           static_cast<std::uint64_t>(k),
                                       k);
        c.publish_samples = false;
        trained_s += run_sim_trial(c).duration_s;
        ++done;
      }
      row.ended_unix_s = db::unix_now_s();
      row.duration_s = trained_s;
      row.trials = done;
      db.add_training(row);
      result.training_trials += done;
      if (stop_requested(options)) break;
    }

    const NamedSettings settings = db.setting(trial.setting_id);
    SimTrialConfig config = base_config(trial.task, settings, trial_seed(who, trial.id),
                                        training_per_task + complete_by_task[trial.task]);
    if (options.configure_trial) options.configure_trial(config, trial);

    SessionProgress started;
    started.phase = SessionProgress::Phase::kTrialStarted;
    started.trial_number = complete + 1;
    started.task = trial.task;
    started.setting = settings.name;
    started.repetition = trial.repetition;
    progress(started);

    const Clock::time_point trial_start = Clock::now();
    SimRig rig(config);
    HapticLoop& loop = rig.loop();
    db.start_trial(trial.id, result.session_id);
    ++result.trials_run;
    db::TrialOutcome outcome;
    std::optional<std::string> storage_failure;  // the writer's error, once the trial is over
    {
      db::SampleWriter writer(db_path, trial.id, loop.samples(), loop.events(), options.writer);
      bool stopped = false;
      if (loop.start()) {
        while (loop.running()) {
          // Storage failed: what the loop produces now is lost, so the
          // trial ends here rather than running on unrecorded.
          if (!stopped && (stop_requested(options) || writer.failed())) {
            loop.request_stop();
            stopped = true;
          }
          std::this_thread::sleep_for(std::chrono::milliseconds(2));
        }
        loop.join();
      }
      if (loop.stop_reason() == StopReason::kStopRequested) {
        // The operator's action is part of the trial's record, at the loop
        // time it took effect, after the VE's events of that update (the
        // writer may still hold them now).
        outcome.closing_events.push_back({trial.id, loop.elapsed_s(), to_string(TaskEventType::kOperatorAbort), -1,
                                          0, "operator stopped the session"});
      }
      outcome.dropped_samples = loop.dropped_samples();
      outcome.dropped_events = loop.dropped_events();
      outcome.timing = loop.timing();
      outcome.device_counters = rig.device().counters();
      switch (loop.stop_reason()) {
        case StopReason::kTaskComplete: outcome.status = db::TrialStatus::kComplete; break;
        case StopReason::kStopRequested:
          outcome.status = db::TrialStatus::kAborted;
          outcome.abort_reason = "operator stopped the session";
          result.stopped_by_operator = true;
          break;
        case StopReason::kMaxDuration:
          outcome.status = db::TrialStatus::kAborted;
          outcome.abort_reason = std::string(kTimeLimitReason) + " (" + std::to_string(options.max_trial_s) +
                                 " s) reached before the task was complete";
          break;
        default:
          outcome.status = db::TrialStatus::kAborted;
          if (loop.device_status() == DeviceStatus::kTimeout) {
            // "device_timeout" first, so a query can match the reason's start.
            const std::string detail = rig.device().fault_detail();
            outcome.abort_reason = std::string(to_string(DeviceStatus::kTimeout)) + (detail.empty() ? "" : ": " + detail);
          } else {
            outcome.abort_reason = std::string("device fault: ") + to_string(loop.device_status());
          }
          result.device_fault = true;
          result.device_fault_reason = outcome.abort_reason;
          break;
      }
      try {
        writer.finish(outcome);
      } catch (const db::DbError& e) {
        storage_failure = e.what();
      }
      result.samples_logged += writer.stats().updates;
    }
    if (storage_failure) {
      // The trial's real end, stored if the database takes this one short
      // write, else left in the lock file for whoever recovers the trial:
      // either way it is never recorded as a crash.
      const std::string reason = std::string(kStorageFailureReason) + ": " + *storage_failure;
      bool recorded = false;
      try {
        db.end_trial(trial.id, db::TrialStatus::kAborted, reason);
        requeue_aborted(db, participant_trials(db, study.id, *participant_id));
        db.end_session(result.session_id, db::SessionStatus::kInterrupted);
        recorded = true;
      } catch (const db::DbError&) {
        lock.record_abort_reason(reason);
      }
      throw std::runtime_error(
          "the study database could not be written, so the session stopped: " + *storage_failure + ". Trial " +
          std::to_string(trial.id) + " was aborted with its samples up to then kept" +
          (recorded ? " and re-queued" : "; the reason is recorded when the session is run again") +
          ". Free disk space, then run the same command to continue.");
    }
    const double trial_sim_s = loop.elapsed_s();
    trial_wall_s += seconds_since(trial_start);
    ++trials_timed;
    if (outcome.status == db::TrialStatus::kComplete) {
      ++result.trials_complete;
      ++complete;
      ++complete_by_task[trial.task];
    } else {
      ++result.trials_aborted;
    }

    SessionProgress finished = started;
    finished.phase = SessionProgress::Phase::kTrialFinished;
    finished.status = outcome.status;
    finished.abort_reason = outcome.abort_reason;
    finished.trial_sim_s = trial_sim_s;
    progress(finished);

    if (outcome.status == db::TrialStatus::kAborted)
      result.trials_requeued += requeue_aborted(db, participant_trials(db, study.id, *participant_id));
    if (result.device_fault) break;
  }
  if (stop_requested(options)) result.stopped_by_operator = true;

  db.end_session(result.session_id,
                 result.device_fault ? db::SessionStatus::kInterrupted : db::SessionStatus::kClosed);
  for (const db::TrialRow& t : participant_trials(db, study.id, *participant_id))
    if (t.status == db::TrialStatus::kPlanned) ++result.trials_left;
  return result;
}

}  // namespace hapticlab::sessions
