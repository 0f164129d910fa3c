#include "sessions/session_runner.h"

#include <chrono>
#include <cmath>
#include <set>
#include <stdexcept>
#include <thread>

#include <nlohmann/json.hpp>

#include "core/common/csv_format.h"
#include "core/common/random.h"
#include "core/device/device_factory.h"
#include "core/loop/task_event.h"
#include "sessions/crash_note.h"
#include "sessions/staircase_planner.h"
#include "sessions/study_session.h"
#include "protocols/protocol_json.h"
#include "protocols/rng.h"
#include "protocols/safety_json.h"

namespace hapticlab::sessions {
namespace {

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
    throw std::invalid_argument("rate_Hz: " + format_number(options.rate_Hz) + " is outside 150..2000 Hz");
  if (!(options.max_trial_s > 0.0) || !std::isfinite(options.max_trial_s))
    throw std::invalid_argument("max_trial_s: " + format_number(options.max_trial_s) +
                                " must be a positive number of seconds");
  if (options.training_trials && (*options.training_trials < 0 || *options.training_trials > 1000))
    throw std::invalid_argument("training_trials: " + std::to_string(*options.training_trials) +
                                " is outside 0..1000");
  if (options.max_trials && *options.max_trials < 0)
    throw std::invalid_argument("max_trials: " + std::to_string(*options.max_trials) + " must be >= 0");
  if (!(options.device_hang_grace_s > 0.0) || !std::isfinite(options.device_hang_grace_s))
    throw std::invalid_argument("device_hang_grace_s: " + format_number(options.device_hang_grace_s) +
                                " must be a positive number of seconds");
}

// Watchdog trips that are the host's, not the device's (a late update, a
// stalled VE step, a slow writer) end only their trial; this many in a row
// mean the machine cannot run the study, and end the session.
constexpr int kMaxWatchdogTripsInARow = 3;

// On the virtual clock no watchdog runs (simulated time waits for the
// loop): a device call that has kept the loop from advancing this long in
// wall time is announced as hung. Long against what a loaded machine can
// hold a thread off the CPU, since here nothing real waits on the device.
constexpr double kVirtualClockHang_s = 2.0;

std::string ms_text(double s) { return std::to_string(static_cast<long long>(std::llround(1e3 * s))) + " ms"; }

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

// The simulated rig has only its own VE's tasks: a study whose protocol
// declares an external VE (its tasks are the lab's own) is run by the lab's
// application through the study API. Refused before the session begins.
void refuse_external_ve(const db::StudyRow& study) {
  const nlohmann::json j = nlohmann::json::parse(study.protocol_json);
  if (j.is_object() && j.value("ve", std::string("simulated")) == "external")
    throw std::runtime_error("study '" + study.name +
                             "': its protocol declares \"ve\": \"external\", so its tasks run in the lab's own "
                             "VE; `session run` drives only the simulated VE (tasks dissection and clip). Run the "
                             "study from the lab's application through the study API (hapticlab/study.h, see "
                             "docs/ve_events.md).");
}

// Why a practice trial ended before its task was complete, said as a
// trial's abort_reason would say it; empty when it was done in full.
std::string practice_cut_short_reason(const SimTrialResult& r, double max_trial_s) {
  if (r.task_complete) return {};
  switch (r.stop_reason) {
    case StopReason::kMaxDuration: return time_limit_reason(format_number(max_trial_s) + " s");
    case StopReason::kSafetyLimit: return "safety limit: " + describe(r.safety_trip);
    case StopReason::kRateViolation: return "rate_violation: " + describe(r.safety_trip);
    case StopReason::kWatchdog:
      return r.safety_trip.kind == SafetyTripKind::kDeviceCallHung ? describe(r.safety_trip)
                                                                   : "watchdog: " + describe(r.safety_trip);
    case StopReason::kDeviceFault: return std::string("device fault: ") + to_string(r.device_status);
    default: return std::string("ended before the task was complete (") + to_string(r.stop_reason) + ")";
  }
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

std::uint64_t training_seed(std::uint64_t participant_seed, std::string_view task, int k) noexcept {
  return Random::derive(participant_seed, protocols::fnv1a64("training:" + std::string(task))).next_u64() +
         static_cast<std::uint64_t>(k);
}

SessionResult run_session(const std::filesystem::path& db_path, const SessionOptions& options) {
  check_options(options);
  // The device is opened (a plugin loaded, a socket bound) and dropped
  // once before anything is stored, so a wrong path, option or port is
  // refused with nothing changed. Each trial opens it again.
  // A plugin is first tried in a child process, which a crash in its code
  // cannot take this one down with.
  probe_device(options.device, DeviceConfig{options.rate_Hz, 0});
  (void)open_device(options.device);
  // Opening, the participant's lock, recovery, re-queueing and the session
  // row: the bookkeeping every runner shares (study_session.h).
  StudySession session(db_path, options.participant, options.device.describe(),
                       options.clock == ClockKind::kVirtual ? "virtual" : "wall", refuse_external_ve);
  db::StudyDb& db = session.db();
  const db::StudyRow& study = session.study();
  SessionResult result;
  result.stale_session = session.stale_session();
  result.trials_requeued = session.requeued_on_open();

  const std::uint64_t who = participant_seed(study.seed, options.participant);
  const int training_per_task =
      options.training_trials.value_or(protocol_training_trials(study.protocol_json, options.participant));
  const std::int64_t training_setting = training_setting_id(db, study.id);
  // A staircase adds up to max_trials trials after the schedule: N counts
  // them as the bound they are.
  const std::optional<protocols::StaircaseSpec> staircase_spec =
      protocols::staircase_from_protocol_text(study.protocol_json, db.path());
  const int scheduled = session.scheduled() + (staircase_spec ? staircase_spec->max_trials : 0);
  result.session_id = session.session_id();
  if (options.on_session_opened) options.on_session_opened(result.session_id);
  const OperatorForceLimits force_limits = protocols::safety_from_protocol_text(study.protocol_json, db.path());
  const double rate_tolerance = protocols::rate_tolerance_from_protocol_text(study.protocol_json, db.path());
  int watchdog_trips_in_a_row = 0;
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
      p.eta_s = trial_wall_s / trials_timed * std::max(0, scheduled - session.complete());
    }
    options.on_progress(p);
  };

  auto base_config = [&](const std::string& task, const NamedSettings& settings, std::uint64_t seed, int practice) {
    SimTrialConfig c;
    c.task = parse_task_kind(task);
    c.device = options.device;
    c.settings = settings.engine;
    c.participant_seed = who;
    c.population = options.population;
    c.trial_seed = seed;
    c.practice_trials = practice;
    c.clock = options.clock;
    c.rate_Hz = options.rate_Hz;
    c.realtime = options.realtime;
    c.max_duration_s = options.max_trial_s;
    c.safety.force_limits = force_limits;
    c.safety.rate.tolerance_fraction = rate_tolerance;
    return c;
  };

  // The device would not be driven: nothing was started, so the session
  // closes with the trial still planned.
  auto refuse = [&](DeviceStatus status, const std::string& what) {
    session.end(db::SessionStatus::kInterrupted);
    const std::string device = "the " + options.device.describe() + " device";
    throw DeviceNotReadyError(
        status == DeviceStatus::kNotCalibrated
            ? "device: " + device + " is not calibrated/homed; calibrate it, then run the session again (" + what +
                  " was not started and stays planned)"
            : "device: " + device + " could not be activated (" + to_string(status) + "); fix it, then run the " +
                  "session again (" + what + " was not started and stays planned)");
  };

  while (!stop_requested(options)) {
    if (options.max_trials && result.trials_run >= *options.max_trials) break;
    std::optional<db::TrialRow> next = session.next_trial();
    // The schedule is done: a staircase (if the protocol has one) adds its
    // next trial, until its stopping rule ends it.
    if (!next) {
      std::optional<analysis::StaircaseProgress> staircase;
      try {
        staircase = plan_next_staircase_trial(db, study, session.participant_id());
      } catch (const analysis::StaircaseBaselineError&) {
        // No baseline: the schedule is done and nothing failed, so the
        // session closes normally before the operator is told why.
        session.end(db::SessionStatus::kClosed);
        throw;
      }
      if (staircase) result.staircase = staircase;
      if (staircase && !staircase->state.finished) next = session.next_trial();
    }
    if (!next) break;
    const db::TrialRow& trial = *next;

    // Training: before this session's first trial of a task. Unlogged
    // sample by sample (it is not analysed); its length and count are kept.
    if (training_per_task > 0 && trained.insert(trial.task).second) {
      // Taken before the training is announced, so an end the operator
      // gives as soon as it shows counts.
      const int ends_before =
          options.training_ends != nullptr ? options.training_ends->load(std::memory_order_acquire) : 0;
      SessionProgress p;
      p.phase = SessionProgress::Phase::kTraining;
      p.trial_number = session.complete() + 1;
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
        SimTrialConfig c = base_config(trial.task, control, training_seed(who, trial.task, k), k);
        c.publish_samples = false;
        const SimTrialResult practice = run_sim_trial(c);
        if (practice.device_refused)
          refuse(practice.device_status, "the training for trial " + std::to_string(trial.id));
        trained_s += practice.duration_s;
        ++done;
        // Recorded as what it was: a practice trial cut short is not one done.
        if (std::string why = practice_cut_short_reason(practice, options.max_trial_s); !why.empty()) {
          ++row.cut_short;
          row.cut_short_reason = std::move(why);
        }
      }
      row.ended_unix_s = db::unix_now_s();
      row.duration_s = trained_s;
      row.trials = done - row.cut_short;
      db.add_training(row);
      result.training_trials += done;
      result.training_cut_short += row.cut_short;
      if (stop_requested(options)) break;
    }

    if (options.hold_before_trial) {
      while (!stop_requested(options) && options.hold_before_trial())
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      if (stop_requested(options)) break;
    }

    const NamedSettings settings = db.setting(trial.setting_id);
    SimTrialConfig config = base_config(trial.task, settings, trial_seed(who, trial.id),
                                        training_per_task + session.complete_of(trial.task));
    if (options.configure_trial) options.configure_trial(config, trial);

    SessionProgress started;
    started.phase = SessionProgress::Phase::kTrialStarted;
    started.trial_number = session.complete() + 1;
    started.trial_id = trial.id;
    started.task = trial.task;
    started.setting = settings.name;
    started.repetition = trial.repetition;
    progress(started);

    const Clock::time_point trial_start = Clock::now();
    // On the heap: a device call that never returns keeps the loop thread
    // inside the rig, which then can never be destroyed (DeviceHungError).
    auto rig_owner = std::make_unique<SimRig>(config);
    SimRig& rig = *rig_owner;
    HapticLoop& loop = rig.loop();
    // Powered before the trial is recorded as started, so a device that is
    // not calibrated or homed leaves the trial planned, not aborted.
    if (!loop.activate()) refuse(loop.device_status(), "trial " + std::to_string(trial.id));
    ++result.trials_run;
    db::TrialOutcome outcome;
    session.start_trial(trial, loop.samples(), loop.events(), options.writer);
    // The writer reads the rig's queues: it must stop before the rig goes,
    // also when something below throws.
    struct AbandonOnUnwind {
      StudySession& session;
      ~AbandonOnUnwind() { session.abandon_trial(); }
    } abandon_on_unwind{session};
    bool stopped = false;
    std::optional<std::string> operator_abort;  // the reason, once the operator aborted this trial
    std::vector<OperatorEvent> actions;
    const auto take_actions = [&](double t_s) {
      if (!options.take_operator_events) return;
      actions.clear();
      options.take_operator_events(actions);
      for (const OperatorEvent& a : actions) {
        if (a.abort && a.trial_id != 0 && a.trial_id != trial.id) {
          outcome.closing_events.push_back({trial.id, t_s, "operator_abort_missed", -1, 0,
                                            "trial " + std::to_string(a.trial_id) + " had ended: " + a.detail});
          continue;
        }
        outcome.closing_events.push_back({trial.id, t_s, a.type, -1, 0, a.detail});
        if (a.abort && !operator_abort) operator_abort = a.detail;
      }
    };
    take_actions(0.0);
    // A crash of this process (an in-process plugin's) leaves its cause in
    // the lock file for the next session's recovery (crash_note.h).
    std::optional<CrashNote> crash_note;
    crash_note.emplace(session.crash_note_target(), loop, rig.device());
    // A device call that does not return: the operator hears of it at once,
    // the lock file says so in case the process is killed now, and after
    // the grace period the session gives up on it.
    std::optional<Clock::time_point> hung_since;
    DeviceCall hung_call = DeviceCall::kNone;
    std::uint64_t last_ticks = 0;
    Clock::time_point ticks_moved = Clock::now();
    if (loop.start()) {
      for (int polls = 0; loop.running(); ++polls) {
        take_actions(loop.elapsed_s());
        const std::uint64_t ticks = loop.ticks();
        if (ticks != last_ticks) {
          last_ticks = ticks;
          ticks_moved = Clock::now();
          // On the virtual clock a call announced as hung that came back
          // was only slow (a loaded machine): the trial goes on as it was.
          if (hung_since && !loop.watchdog_tripped()) {
            hung_since.reset();
            session.clear_pending_reason();
            if (options.on_alert) options.on_alert("the device call of trial " + std::to_string(trial.id) +
                                                   " returned after all; the trial goes on");
          }
        }
        if (!hung_since) {
          const DeviceCall in_call = loop.device_call().load(std::memory_order_acquire);
          const bool tripped = loop.watchdog_tripped();
          const bool virtual_hang = options.clock == ClockKind::kVirtual && in_call != DeviceCall::kNone &&
                                    seconds_since(ticks_moved) > kVirtualClockHang_s;
          if (tripped || virtual_hang) {
            hung_since = Clock::now();
            hung_call = tripped ? loop.watchdog_call() : in_call;
            const double limit_s = tripped ? loop.watchdog_limit_s() : kVirtualClockHang_s;
            const std::string what = hung_call != DeviceCall::kNone
                                         ? "device " + std::string(to_string(hung_call)) + "() has not returned"
                                         : std::string("the haptic loop has completed no update");
            if (options.on_alert)
              options.on_alert(what + " for " + ms_text(limit_s) + (tripped ? "" : " of wall time") + " in trial " +
                               std::to_string(trial.id) +
                               (tripped ? "; the watchdog halted the device (zero force)" : ""));
            if (hung_call != DeviceCall::kNone)
              session.record_pending_reason("device " + std::string(to_string(hung_call)) + " hung for at least " +
                                            ms_text(limit_s) + " (the session ended before it returned)");
          }
        }
        if (hung_since && hung_call != DeviceCall::kNone && loop.running() && loop.ticks() == last_ticks &&
            seconds_since(*hung_since) > options.device_hang_grace_s) {
          // The loop thread is inside the device's code: record the trial and
          // the session from here, and leave the rig to the stuck thread
          // (told to stop, should the call ever return).
          loop.request_stop();
          const double hung_s = seconds_since(*hung_since) +
                                (options.clock == ClockKind::kVirtual ? kVirtualClockHang_s : loop.watchdog_limit_s());
          outcome.status = db::TrialStatus::kAborted;
          outcome.abort_reason = "device " + std::string(to_string(hung_call)) + " hung for " + ms_text(hung_s) +
                                 " and had not returned when the session gave up on it";
          outcome.dropped_samples = loop.dropped_samples();
          outcome.dropped_events = loop.dropped_events();
          outcome.timing = loop.timing();
          crash_note.reset();
          session.finish_trial(outcome);
          session.clear_pending_reason();
          session.end(db::SessionStatus::kInterrupted);
          (void)rig_owner.release();
          throw DeviceHungError(outcome.abort_reason + " (trial " + std::to_string(trial.id) +
                                ", re-queued with its samples up to the hang). The device's code cannot be "
                                "stopped inside this process: restart the device, then run the session again; "
                                "an isolated plugin (docs/devices.md) is killed and restarted instead");
        }
        // timing() reads a histogram (~100 µs): every 50th poll, ~100 ms.
        if (options.on_loop_status && polls % 50 == 0)
          options.on_loop_status({loop.elapsed_s(), loop.timing(), loop.dropped_samples()});
        // Storage failed: what the loop produces now is lost, so the
        // trial ends here rather than running on unrecorded.
        if (!stopped && (stop_requested(options) || operator_abort || session.writer_failed())) {
          loop.request_stop();
          stopped = true;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
      }
      loop.join();
    }
    crash_note.reset();
    if (hung_since && hung_call != DeviceCall::kNone) session.clear_pending_reason();
    // A stall the polls above missed (this thread was not scheduled in
    // time): said now, never not at all.
    if (!hung_since && loop.watchdog_tripped() && options.on_alert)
      options.on_alert("the watchdog halted the device (zero force) in trial " + std::to_string(trial.id) + ": " +
                       describe(loop.safety_trip()));
    if (loop.stop_reason() == StopReason::kStopRequested && operator_abort) {
      // Ended by the operator's abort (its event is in closing_events);
      // re-queued, and the session goes on.
      outcome.status = db::TrialStatus::kAborted;
      outcome.abort_reason = "operator abort: " + *operator_abort;
    } else if (loop.stop_reason() == StopReason::kStopRequested) {
      // The operator's action is part of the trial's record, at the loop
      // time it took effect, after the VE's events of that update (the
      // writer may still hold them now).
      outcome.closing_events.push_back({trial.id, loop.elapsed_s(), to_string(TaskEventType::kOperatorAbort), -1, 0,
                                        std::string(kOperatorStopReason)});
    }
    outcome.dropped_samples = loop.dropped_samples();
    outcome.dropped_events = loop.dropped_events();
    outcome.timing = loop.timing();
    outcome.device_counters = rig.device().counters();
    const bool aborted_by_operator = operator_abort && loop.stop_reason() == StopReason::kStopRequested;
    if (!aborted_by_operator) switch (loop.stop_reason()) {
      case StopReason::kTaskComplete: outcome.status = db::TrialStatus::kComplete; break;
      case StopReason::kStopRequested:
        outcome.status = db::TrialStatus::kAborted;
        outcome.abort_reason = kOperatorStopReason;
        result.stopped_by_operator = true;
        break;
      case StopReason::kMaxDuration:
        outcome.status = db::TrialStatus::kAborted;
        outcome.abort_reason = time_limit_reason(format_number(options.max_trial_s) + " s");
        break;
      case StopReason::kSafetyLimit:
        // Zero force was commanded; re-queued like a device fault.
        outcome.status = db::TrialStatus::kAborted;
        outcome.abort_reason = "safety limit: " + describe(loop.safety_trip());
        result.device_fault = true;
        result.device_fault_reason = outcome.abort_reason;
        break;
      case StopReason::kRateViolation:
        // The rate is a controlled variable: the trial measured another
        // condition. Re-queued; a device that cannot keep the rate will not
        // keep it in the next trial either, so the session ends.
        outcome.status = db::TrialStatus::kAborted;
        outcome.abort_reason = "rate_violation: " + describe(loop.safety_trip());
        result.device_fault = true;
        result.device_fault_reason = outcome.abort_reason;
        break;
      case StopReason::kWatchdog:
        outcome.status = db::TrialStatus::kAborted;
        if (loop.safety_trip().kind == SafetyTripKind::kDeviceCallHung) {
          // The device's own call hung: a device fault, as a timeout is.
          outcome.abort_reason = describe(loop.safety_trip());
          result.device_fault = true;
          result.device_fault_reason = outcome.abort_reason;
          break;
        }
        // The host fell behind (a late update, a stalled step, a slow
        // writer): zero force was commanded, the trial is re-queued and the
        // session goes on, unless it keeps happening.
        outcome.abort_reason = "watchdog: " + describe(loop.safety_trip());
        if (++watchdog_trips_in_a_row >= kMaxWatchdogTripsInARow) {
          result.device_fault = true;
          result.device_fault_reason = outcome.abort_reason + " (" + std::to_string(kMaxWatchdogTripsInARow) +
                                       " trials in a row; this machine cannot keep the loop's timing now)";
        }
        break;
      default:
        outcome.status = db::TrialStatus::kAborted;
        if (loop.device_status() == DeviceStatus::kTimeout) {
          // "device_timeout" first, so a query can match the reason's start.
          const std::string detail = rig.device().fault_detail();
          outcome.abort_reason = std::string(to_string(DeviceStatus::kTimeout)) + (detail.empty() ? "" : ": " + detail);
        } else if (const std::string detail = rig.device().fault_detail();
                   !detail.empty() && (loop.device_status() == DeviceStatus::kDeviceCrashed ||
                                       loop.device_status() == DeviceStatus::kDeviceHung)) {
          // An isolated plugin's process: the device names it in full
          // ("device_crashed: SIGSEGV in read", "device read hung for 15 ms").
          outcome.abort_reason = detail;
        } else {
          outcome.abort_reason = std::string("device fault: ") + to_string(loop.device_status());
        }
        result.device_fault = true;
        result.device_fault_reason = outcome.abort_reason;
        break;
    }
    if (loop.stop_reason() != StopReason::kWatchdog) watchdog_trips_in_a_row = 0;
    // Throws, with the session recorded as interrupted, on a storage failure.
    result.samples_logged += session.finish_trial(outcome);
    const double trial_sim_s = loop.elapsed_s();
    trial_wall_s += seconds_since(trial_start);
    ++trials_timed;
    if (outcome.status == db::TrialStatus::kComplete) {
      ++result.trials_complete;
    } else {
      ++result.trials_aborted;
    }

    SessionProgress finished = started;
    finished.phase = SessionProgress::Phase::kTrialFinished;
    finished.status = outcome.status;
    finished.abort_reason = outcome.abort_reason;
    finished.trial_sim_s = trial_sim_s;
    progress(finished);

    if (result.device_fault) break;
  }
  if (stop_requested(options)) result.stopped_by_operator = true;

  session.end(result.device_fault ? db::SessionStatus::kInterrupted : db::SessionStatus::kClosed);
  result.trials_requeued += session.requeued();
  result.trials_left = session.trials_left();
  return result;
}

}  // namespace hapticlab::sessions
