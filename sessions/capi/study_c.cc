// The C study API (hapticlab/study.h): a thin shell over StudySession, the
// bookkeeping `session run` uses too. No exception crosses it.
#include "hapticlab/study.h"

#include <atomic>
#include <cmath>
#include <limits>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>

#include "core/loop/force_guard.h"
#include "core/loop/haptic_loop.h"
#include "core/loop/loop_sample.h"
#include "core/loop/loop_timing.h"
#include "core/loop/spsc_queue.h"
#include "core/loop/task_event.h"
#include "db/session_lock.h"
#include "db/study_db.h"
#include "sessions/capi/study_text.h"
#include "sessions/capi/study_timing.h"
#include "sessions/study_session.h"

namespace {

namespace hl = hapticlab;

// The queues of `session run`'s loop (LoopConfig), as study.h documents them.
constexpr std::size_t kSampleQueueCapacity = HL_STUDY_SAMPLE_QUEUE_CAPACITY;
constexpr std::size_t kEventQueueCapacity = HL_STUDY_EVENT_QUEUE_CAPACITY;
static_assert(kSampleQueueCapacity == hl::LoopConfig{}.sample_queue_capacity);
static_assert(kEventQueueCapacity == hl::LoopConfig{}.event_queue_capacity);

static_assert(HL_EVENT_INSERTION_PASSED == static_cast<int>(hl::TaskEventType::kInsertionPassed));
static_assert(HL_EVENT_INSERTION_WITHDRAWN == static_cast<int>(hl::TaskEventType::kInsertionWithdrawn));
static_assert(HL_EVENT_CONTACT_START == static_cast<int>(hl::TaskEventType::kContactStart));
static_assert(HL_EVENT_CONTACT_END == static_cast<int>(hl::TaskEventType::kContactEnd));
static_assert(HL_EVENT_GRASP_START == static_cast<int>(hl::TaskEventType::kGraspStart));
static_assert(HL_EVENT_GRASP_END == static_cast<int>(hl::TaskEventType::kGraspEnd));
static_assert(HL_EVENT_TASK_COMPLETE == static_cast<int>(hl::TaskEventType::kTaskComplete));
// The types study.h defines. The simulated VE's own (tissue_removed,
// clip_applied, clip_missed: 6..8) and operator_abort, which the API logs
// itself (hl_study_request_stop), are not the application's to log.
constexpr bool is_ve_event_type(int type) noexcept {
  return (type >= HL_EVENT_INSERTION_PASSED && type <= HL_EVENT_GRASP_END) || type == HL_EVENT_TASK_COMPLETE;
}

void write_error(char* error, size_t size, const std::string& message) {
  if (error != nullptr && size > 0) std::snprintf(error, size, "%s", message.c_str());
}

void copy_text(char* out, size_t size, const std::string& text) {
  if (out != nullptr && size > 0) std::snprintf(out, size, "%s", text.c_str());
}

}  // namespace

struct hl_study {
  explicit hl_study(std::filesystem::path path) : db_path(std::move(path)) {}

  const std::filesystem::path db_path;
  // Declared before the session: its writer reads them, so they outlive it.
  hl::SpscQueue<hl::LoopSample> samples{kSampleQueueCapacity};
  hl::SpscQueue<hl::TaskEvent> events{kEventQueueCapacity};
  hl::LoopTimingStats timing;  // the application's periods (dt_s), for the trial's loop_timing
  std::unique_ptr<hl::sessions::StudySession> session;

  // The open trial. trial_open gates the logging calls (loop thread);
  // engine is shared with hl_study_request_stop (any thread) under mutex.
  std::optional<hl::db::TrialRow> trial;
  std::atomic<bool> trial_open{false};
  // The trial's sample writer failed (SampleWriterConfig::failed_flag): the
  // log calls say so instead of accepting data that is thrown away.
  std::atomic<bool> storage_failed{false};
  std::mutex engine_mutex;
  hl_engine* engine = nullptr;

  // An operator stop holds until the session it stopped is over; one made
  // while no session is open stops the next session before its first trial
  // (a stop answered HL_OK must never be forgotten: hl_study_request_stop).
  std::atomic<bool> stop{false};
  std::atomic<std::uint64_t> dropped_samples{0};
  std::atomic<std::uint64_t> dropped_events{0};
  // Refused at the call (HL_ERROR_INVALID_ARGUMENT) and counted, so a bad
  // sample never reaches the writer, whose chunks must not overlap in ticks.
  std::atomic<std::uint64_t> rejected_samples{0};
  std::atomic<std::uint64_t> rejected_events{0};
  // The loop thread's own: the tick of the last sample accepted this trial.
  bool have_tick = false;
  std::uint64_t last_tick = 0;
  // A sample of this trial reached the writer's queue: a trial may be
  // stored complete only then (hl_study_end_trial may run on another
  // thread than the loop's, hence atomic).
  std::atomic<bool> sample_queued{false};
  double last_sample_t_s = 0.0;  // of the last sample accepted (the loop thread's)
  std::atomic<double> last_t_s{0.0};  // of the last sample logged: when a stop took effect
  // The first and last sample whose period `timing` holds: its periods are
  // checked against their times as the trial ends (study_timing.h).
  bool timed_any = false;  // the loop thread's
  std::atomic<std::uint64_t> first_timed_tick{0}, last_timed_tick{0};
  std::atomic<double> first_timed_t_s{0.0};
};

namespace {

// Ends the open trial: the writer stores the rest, then the outcome. On a
// storage failure StudySession has recorded what it could and ended the
// session; the handle lets it go.
int finish_trial(hl_study& s, hl::db::TrialOutcome outcome, char* error, size_t error_size) {
  s.trial_open.store(false, std::memory_order_release);
  {
    std::lock_guard<std::mutex> lock(s.engine_mutex);
    hl_engine_destroy(s.engine);
    s.engine = nullptr;
  }
  outcome.dropped_samples = s.dropped_samples.load(std::memory_order_relaxed);
  outcome.dropped_events = s.dropped_events.load(std::memory_order_relaxed);
  outcome.device_counters.emplace_back("rejected_samples", s.rejected_samples.load(std::memory_order_relaxed));
  outcome.device_counters.emplace_back("rejected_events", s.rejected_events.load(std::memory_order_relaxed));
  outcome.timing = s.timing.summary();
  const hl::sessions::TimedSpan span{s.first_timed_tick.load(std::memory_order_relaxed),
                                     s.last_timed_tick.load(std::memory_order_relaxed),
                                     s.first_timed_t_s.load(std::memory_order_relaxed),
                                     s.last_t_s.load(std::memory_order_relaxed)};
  const std::optional<std::string> mismatch = hl::sessions::timing_mismatch(outcome.timing, span);
  if (mismatch)
    outcome.closing_events.push_back({s.trial->id, span.last_t_s, "loop_timing_mismatch", -1, 0, *mismatch});
  s.trial.reset();
  try {
    s.session->finish_trial(outcome);
  } catch (const std::exception& e) {
    write_error(error, error_size, e.what());
    s.session.reset();
    return HL_ERROR_DATABASE;
  }
  // Stored, and told: the trial is kept (its times are what the analysis
  // reads), but the rate it records is not the trial's.
  write_error(error, error_size, mismatch ? "loop timing of the trial: " + *mismatch : std::string());
  return HL_OK;
}

// The trial's setting as the study stored it. One that was edited since
// (or cannot be read): no trial of the session may run on it, and the
// session ends here, interrupted, as a storage failure ends it (a later
// hl_study_end_session would record it closed); nullopt, with the error
// written.
std::optional<std::string> trial_setting(hl_study& s, std::int64_t setting_id, char* error, size_t error_size) {
  try {
    return s.session->db().setting_json(setting_id);
  } catch (const hl::db::DbError& e) {
    write_error(error, error_size,
                std::string(e.what()) + "; the session is ended (interrupted): put the setting back, then start a "
                                        "new session");
    try {
      s.session->end(hl::db::SessionStatus::kInterrupted);
    } catch (const std::exception&) {
      // Left as a crash leaves it: the participant's next session recovers it.
    }
    s.session.reset();
    return std::nullopt;
  }
}

// Before a trial: whatever a late call left in the queues belongs to no
// trial (the writer is not running, so this thread may consume), and the
// counters and the tick timing start again.
void reset_trial_streams(hl_study& study) {
  hl::LoopSample stale_sample;
  while (study.samples.try_pop(stale_sample)) {
  }
  hl::TaskEvent stale_event;
  while (study.events.try_pop(stale_event)) {
  }
  study.dropped_samples.store(0, std::memory_order_relaxed);
  study.dropped_events.store(0, std::memory_order_relaxed);
  study.rejected_samples.store(0, std::memory_order_relaxed);
  study.rejected_events.store(0, std::memory_order_relaxed);
  study.storage_failed.store(false, std::memory_order_relaxed);
  study.have_tick = false;
  study.sample_queued.store(false, std::memory_order_relaxed);
  study.last_sample_t_s = 0.0;
  study.last_t_s.store(0.0, std::memory_order_relaxed);
  study.timed_any = false;
  study.timing.reset();
}

// Starts the trial's writer and hands the application `engine` (taken over:
// destroyed if the writer cannot start).
void begin_trial(hl_study& study, const hl::db::TrialRow& next, hl_engine* engine) {
  reset_trial_streams(study);
  try {
    hl::db::SampleWriterConfig writer;
    writer.failed_flag = &study.storage_failed;
    // Nothing recorded from now on: zero force from the next update. The
    // flag is set under the engine's lock too, for the check below.
    writer.on_failure = [&study] {
      std::lock_guard<std::mutex> lock(study.engine_mutex);
      study.storage_failed.store(true, std::memory_order_release);
      hl_engine_halt(study.engine);
    };
    study.session->start_trial(next, study.samples, study.events, writer);
  } catch (...) {
    hl_engine_destroy(engine);
    throw;
  }
  study.trial = next;
  std::lock_guard<std::mutex> lock(study.engine_mutex);
  study.engine = engine;
  // A stop, or a writer that failed, while the trial was set up counts.
  if (study.stop.load(std::memory_order_acquire) || study.storage_failed.load(std::memory_order_acquire))
    hl_engine_halt(engine);
}

}  // namespace

extern "C" {

hl_study* hl_study_open(const char* db_path, char* error, size_t error_size) {
  if (db_path == nullptr) {
    write_error(error, error_size, "hl_study_open: db_path is NULL");
    return nullptr;
  }
  try {
    if (!std::filesystem::exists(db_path)) {
      write_error(error, error_size,
                  std::string(db_path) + ": no such database (create it with `hapticlab study create`)");
      return nullptr;
    }
    // SQLite would write a new, empty database into it (the header promises
    // that nothing changes until a session starts).
    if (std::filesystem::is_regular_file(db_path) && std::filesystem::file_size(db_path) == 0) {
      write_error(error, error_size,
                  std::string(db_path) + ": the file is empty: it holds no study (run `hapticlab study create` first)");
      return nullptr;
    }
    // Checked now so a wrong file is reported before a session is tried;
    // recovery waits for the participant's lock (hl_study_start_session).
    hl::db::OpenOptions open;
    open.recover = false;
    open.integrity = hl::db::OpenOptions::Integrity::kQuick;
    hl::db::StudyDb db(db_path, open);
    if (db.studies().empty()) {
      write_error(error, error_size, db.path() + ": holds no study (run `hapticlab study create` first)");
      return nullptr;
    }
    write_error(error, error_size, "");
    return new hl_study(db_path);
  } catch (const std::exception& e) {
    write_error(error, error_size, e.what());
  } catch (...) {
    write_error(error, error_size, "unknown error");
  }
  return nullptr;
}

int hl_study_start_session(hl_study* study, const char* participant_code, const char* device, char* error,
                           size_t error_size) {
  if (study == nullptr || participant_code == nullptr) {
    write_error(error, error_size, "hl_study_start_session: study or participant_code is NULL");
    return HL_ERROR_INVALID_ARGUMENT;
  }
  if (device != nullptr && !hl::sessions::printable_name(device)) {
    write_error(error, error_size,
                "hl_study_start_session: device is not a printable UTF-8 name (it is stored with the session and "
                "shown to the operator); nothing was started");
    return HL_ERROR_INVALID_ARGUMENT;
  }
  if (study->session) {
    write_error(error, error_size,
                "hl_study_start_session: a session of participant '" + study->session->participant() +
                    "' is open on this handle; end it first (hl_study_end_session)");
    return HL_ERROR_STATE;
  }
  try {
    study->session = std::make_unique<hl::sessions::StudySession>(
        study->db_path, participant_code, device != nullptr && *device != '\0' ? device : "external", "wall",
        std::nullopt);  // the integrator's own loop: its rate is not known here
    std::string note;
    if (study->session->stale_session())
      note = "the participant's previous session had died (" + *study->session->stale_session() +
             "); its running trial was recovered";
    write_error(error, error_size, note);
    return HL_OK;
  } catch (const hl::db::SessionBusyError& e) {
    write_error(error, error_size, e.what());
    return HL_ERROR_BUSY;
  } catch (const hl::db::DbError& e) {
    write_error(error, error_size, e.what());
    return HL_ERROR_DATABASE;
  } catch (const std::exception& e) {
    write_error(error, error_size, e.what());
    return HL_ERROR_STUDY;
  }
}

int hl_study_next_trial(hl_study* study, hl_trial* trial, char* operator_setting, size_t operator_setting_size,
                        char* error, size_t error_size) {
  if (study == nullptr || trial == nullptr) {
    write_error(error, error_size, "hl_study_next_trial: study or trial is NULL");
    return HL_ERROR_INVALID_ARGUMENT;
  }
  if (!study->session) {
    write_error(error, error_size, "hl_study_next_trial: no session is open (hl_study_start_session)");
    return HL_ERROR_STATE;
  }
  if (study->trial) {
    write_error(error, error_size,
                "hl_study_next_trial: trial " + std::to_string(study->trial->id) +
                    " is still open; end it first (hl_study_end_trial)");
    return HL_ERROR_STATE;
  }
  if (study->stop.load(std::memory_order_acquire)) {
    write_error(error, error_size,
                "the operator stopped the session (hl_study_request_stop); no trial starts until it is ended");
    return HL_STUDY_STOPPED;
  }
  try {
    hl::sessions::StudySession& session = *study->session;
    const std::optional<hl::db::TrialRow> next = session.next_trial();
    if (!next) {
      write_error(error, error_size, "");
      return HL_STUDY_DONE;
    }
    const std::optional<std::string> setting_json = trial_setting(*study, next->setting_id, error, error_size);
    if (!setting_json) return HL_ERROR_DATABASE;
    char engine_error[512] = "";
    hl_engine* engine = hl_engine_create(setting_json->c_str(), engine_error, sizeof engine_error);
    if (engine == nullptr) {
      write_error(error, error_size,
                  session.db().path() + ": setting " + std::to_string(next->setting_id) +
                      " of the study cannot configure an engine: " + engine_error);
      return HL_ERROR_DATABASE;
    }
    // The trial starts with its forces ramping in, as in HapticLab's own loop.
    hl_engine_set_ramp_in(engine, hl::ForceGuard::kDefaultRampIn_s);
    // What the participant feels is the setting stored for the trial, with
    // the loop's safety ramp: the application cannot change either.
    hl_engine_fix_settings(engine);
    begin_trial(*study, *next, engine);
    *trial = hl_trial{};
    trial->trial_id = next->id;
    copy_text(trial->task, sizeof trial->task, next->task);
    trial->repetition = next->repetition;
    trial->trial_number = session.complete() + 1;
    trial->trial_count = session.scheduled();
    trial->engine = engine;
    copy_text(operator_setting, operator_setting_size, session.db().trial(next->id).setting_name);
    study->trial_open.store(true, std::memory_order_release);
    write_error(error, error_size, "");
    return HL_OK;
  } catch (const std::exception& e) {
    write_error(error, error_size, e.what());
    return HL_ERROR_DATABASE;
  }
}

namespace {

// Whether a sample can be stored as given: its tick increases and fits the
// file's 64-bit signed ticks (a chunk's end, one past its last tick, must
// fit too: INT64_MAX itself is refused, or every reader would call its
// chunk damaged and the trial would lose its measures), its time is a
// number that does not go back, its period is a number >= 0, and every physical value is finite (a NaN
// force or joint would be stored, exported and analysed as a value).
// The physical channels are stored as float32 (db/sample_codec.h): a finite
// double beyond its range would be stored as infinity, and the trial,
// accepted complete, then voided by the analysis.
bool fits_stored_float(double v) { return std::abs(v) <= static_cast<double>(std::numeric_limits<float>::max()); }

bool storable(const hl_study& study, const hl_sample& s) {
  if (s.tick >= static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) return false;
  if (study.have_tick && (s.tick <= study.last_tick || s.t_s < study.last_sample_t_s)) return false;
  if (!std::isfinite(s.t_s) || !std::isfinite(s.dt_s) || s.dt_s < 0.0) return false;
  for (const hl_sample_instrument& in : s.instrument) {
    // NaN fails the comparison too.
    for (double v : in.raw_joints)
      if (!fits_stored_float(v)) return false;
    for (const double* field : {in.degraded_joints, in.tip_position_m, in.tip_velocity_m_per_s, in.ve_force_N,
                                in.displayed_force_N, in.joint_force})
      for (int j = 0; j < 3; ++j)
        if (!fits_stored_float(field[j])) return false;
  }
  return true;
}

}  // namespace

int hl_study_log_sample(hl_study* study, const hl_sample* sample) {
  if (study == nullptr || sample == nullptr) return HL_ERROR_INVALID_ARGUMENT;
  if (!study->trial_open.load(std::memory_order_acquire)) return HL_ERROR_STATE;
  // A tick that does not increase (a repeated update, a counter reset), a
  // time that goes back or is not a number, or a value that is not would
  // put wrong samples in the trial: refused here, and the trial goes on.
  if (!storable(*study, *sample)) {
    study->rejected_samples.fetch_add(1, std::memory_order_relaxed);
    return HL_ERROR_INVALID_ARGUMENT;
  }
  study->have_tick = true;
  study->last_tick = sample->tick;
  study->last_sample_t_s = sample->t_s;
  hl::LoopSample s;
  s.tick = sample->tick;
  s.t_s = sample->t_s;
  s.dt_s = sample->dt_s;
  s.device_status = sample->device_status;
  for (std::size_t i = 0; i < 2; ++i) {
    const hl_sample_instrument& in = sample->instrument[i];
    hl::InstrumentSample& out = s.instrument[i];
    for (std::size_t j = 0; j < 5; ++j) out.raw_position[j] = in.raw_joints[j];
    for (std::size_t j = 0; j < 3; ++j) {
      out.degraded_position[j] = in.degraded_joints[j];
      out.tip_position_m[j] = in.tip_position_m[j];
      out.tip_velocity_m_per_s[j] = in.tip_velocity_m_per_s[j];
      out.ve_force_N[j] = in.ve_force_N[j];
      out.displayed_force_N[j] = in.displayed_force_N[j];
      out.joint_force[j] = in.joint_force[j];
    }
    out.engine_status = in.engine_status;
    out.in_contact = in.in_contact != 0;
  }
  // Checked before anything is counted: once storage failed, nothing this
  // trial logs is kept, and the application must end the trial.
  if (study->storage_failed.load(std::memory_order_acquire)) return HL_ERROR_DATABASE;
  study->timing.record(sample->dt_s, false);
  study->last_t_s.store(sample->t_s, std::memory_order_relaxed);
  if (!study->timed_any) {
    study->timed_any = true;
    study->first_timed_tick.store(sample->tick, std::memory_order_relaxed);
    study->first_timed_t_s.store(sample->t_s, std::memory_order_relaxed);
  }
  study->last_timed_tick.store(sample->tick, std::memory_order_relaxed);
  if (!study->samples.try_push(s)) {
    study->dropped_samples.fetch_add(1, std::memory_order_relaxed);
    return HL_STUDY_DROPPED;
  }
  // A load first: the store, once per trial, is the only write.
  if (!study->sample_queued.load(std::memory_order_relaxed))
    study->sample_queued.store(true, std::memory_order_release);
  return HL_OK;
}

int hl_study_log_event(hl_study* study, double t_s, int type, int instrument, int32_t index) {
  if (study == nullptr) return HL_ERROR_INVALID_ARGUMENT;
  if (!study->trial_open.load(std::memory_order_acquire)) return HL_ERROR_STATE;
  // The task's completion is the task's (-1); the others are an instrument's
  // (0 or 1): an event of the wrong kind would count for the wrong hand.
  const bool task_event = type == HL_EVENT_TASK_COMPLETE;
  if (!is_ve_event_type(type) || (task_event ? instrument != -1 : instrument != 0 && instrument != 1) ||
      !std::isfinite(t_s) || index < 0) {
    study->rejected_events.fetch_add(1, std::memory_order_relaxed);
    return HL_ERROR_INVALID_ARGUMENT;
  }
  if (study->storage_failed.load(std::memory_order_acquire)) return HL_ERROR_DATABASE;
  const hl::TaskEvent e{t_s, static_cast<hl::TaskEventType>(type), static_cast<std::int8_t>(instrument), index};
  if (!study->events.try_push(e)) {
    study->dropped_events.fetch_add(1, std::memory_order_relaxed);
    return HL_STUDY_DROPPED;
  }
  return HL_OK;
}

int hl_study_dropped(const hl_study* study, uint64_t* samples, uint64_t* events) {
  if (study == nullptr) return HL_ERROR_INVALID_ARGUMENT;
  if (samples != nullptr) *samples = study->dropped_samples.load(std::memory_order_relaxed);
  if (events != nullptr) *events = study->dropped_events.load(std::memory_order_relaxed);
  return HL_OK;
}

int hl_study_rejected(const hl_study* study, uint64_t* samples, uint64_t* events) {
  if (study == nullptr) return HL_ERROR_INVALID_ARGUMENT;
  if (samples != nullptr) *samples = study->rejected_samples.load(std::memory_order_relaxed);
  if (events != nullptr) *events = study->rejected_events.load(std::memory_order_relaxed);
  return HL_OK;
}

int hl_study_end_trial(hl_study* study, int outcome, const char* reason, char* error, size_t error_size) {
  if (study == nullptr) {
    write_error(error, error_size, "hl_study_end_trial: study is NULL");
    return HL_ERROR_INVALID_ARGUMENT;
  }
  if (!study->trial) {
    write_error(error, error_size, "hl_study_end_trial: no trial is open (hl_study_next_trial)");
    return HL_ERROR_STATE;
  }
  const std::string why = reason != nullptr ? reason : "";
  // After a stop the outcome and reason given are not stored (below).
  if (!study->stop.load(std::memory_order_acquire)) {
    if (const std::string problem = hl::sessions::reason_problem(outcome, why); !problem.empty()) {
      write_error(error, error_size, "hl_study_end_trial: " + problem + "; the trial is still open");
      return HL_ERROR_INVALID_ARGUMENT;
    }
  }
  hl::db::TrialOutcome out;
  switch (outcome) {
    case HL_TRIAL_COMPLETE: out.status = hl::db::TrialStatus::kComplete; break;
    case HL_TRIAL_ABORTED:
      out.status = hl::db::TrialStatus::kAborted;
      out.abort_reason = why;
      break;
    case HL_TRIAL_TIME_LIMIT:
      out.status = hl::db::TrialStatus::kAborted;
      out.abort_reason = hl::sessions::time_limit_reason(hl::sessions::blank(why) ? "set by the application" : why);
      break;
    default:
      write_error(error, error_size,
                  "hl_study_end_trial: outcome " + std::to_string(outcome) +
                      " is not HL_TRIAL_COMPLETE (0), HL_TRIAL_ABORTED (1) or HL_TRIAL_TIME_LIMIT (2); the trial "
                      "is still open");
      return HL_ERROR_INVALID_ARGUMENT;
  }
  if (study->stop.load(std::memory_order_acquire)) {
    // The participant felt zero force from the stop on: whatever the VE
    // says, the trial did not run to its end as planned.
    const std::string stop_reason(hl::sessions::kOperatorStopReason);
    out.status = hl::db::TrialStatus::kAborted;
    out.abort_reason = stop_reason;
    out.closing_events.push_back({study->trial->id, study->last_t_s.load(std::memory_order_relaxed),
                                  hl::to_string(hl::TaskEventType::kOperatorAbort), -1, 0, stop_reason});
  } else if (outcome != HL_TRIAL_ABORTED && !study->sample_queued.load(std::memory_order_acquire) &&
             !study->storage_failed.load(std::memory_order_acquire)) {
    // Complete, it would count as done in the schedule, and a time limit
    // closes its slot; either way the trial would then be left out of
    // every metric ("no samples logged"): the participant's slot for this
    // setting lost without a word. (After a storage failure finish_trial
    // says that, and aborts the trial.)
    const std::uint64_t rejected = study->rejected_samples.load(std::memory_order_relaxed);
    const std::uint64_t dropped = study->dropped_samples.load(std::memory_order_relaxed);
    write_error(error, error_size,
                "hl_study_end_trial: trial " + std::to_string(study->trial->id) +
                    " cannot be " + (outcome == HL_TRIAL_COMPLETE ? "complete" : "closed by a time limit") +
                    ": no sample of it was logged (hl_study_log_sample accepted none; " +
                    std::to_string(rejected) + " refused as invalid, " + std::to_string(dropped) +
                    " dropped). The trial is still open: log its samples, or end it with HL_TRIAL_ABORTED and a "
                    "reason");
    return HL_ERROR_STATE;
  }
  return finish_trial(*study, std::move(out), error, error_size);
}

int hl_study_request_stop(hl_study* study) {
  if (study == nullptr) return HL_ERROR_INVALID_ARGUMENT;
  study->stop.store(true, std::memory_order_release);
  std::lock_guard<std::mutex> lock(study->engine_mutex);
  hl_engine_halt(study->engine);
  return HL_OK;
}

int hl_study_end_session(hl_study* study, char* error, size_t error_size) {
  if (study == nullptr) {
    write_error(error, error_size, "hl_study_end_session: study is NULL");
    return HL_ERROR_INVALID_ARGUMENT;
  }
  if (!study->session) {
    write_error(error, error_size, "hl_study_end_session: no session is open (already ended, or never started)");
    return HL_ERROR_STATE;
  }
  if (study->trial) {
    write_error(error, error_size,
                "hl_study_end_session: trial " + std::to_string(study->trial->id) +
                    " is still open; end it first (hl_study_end_trial)");
    return HL_ERROR_STATE;
  }
  // A stop made for this session has done its work once it ends; one that
  // comes while it is being ended is kept for the next. (A session lost to a
  // storage failure keeps its stop too: the next one then starts stopped.)
  const bool stopped = study->stop.exchange(false, std::memory_order_acq_rel);
  try {
    study->session->end(hl::db::SessionStatus::kClosed);
    study->session.reset();  // releases the participant's lock
    write_error(error, error_size, "");
    return HL_OK;
  } catch (const std::exception& e) {
    if (stopped) study->stop.store(true, std::memory_order_release);  // still open, still stopped
    write_error(error, error_size, e.what());
    return HL_ERROR_DATABASE;
  }
}

void hl_study_close(hl_study* study) {
  if (study == nullptr) return;
  try {
    if (study->trial) {
      hl::db::TrialOutcome out;
      out.status = hl::db::TrialStatus::kAborted;
      out.abort_reason = "the application closed the study with the trial open";
      finish_trial(*study, std::move(out), nullptr, 0);
    }
    if (study->session) study->session->end(hl::db::SessionStatus::kInterrupted);
  } catch (...) {
    // Left as a crash would leave it: the next session recovers it.
  }
  delete study;
}

}  // extern "C"
