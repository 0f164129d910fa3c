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
#include "sessions/nothing_to_run.h"
#include "sessions/sitting_gate.h"
#include "sessions/staircase_planner.h"
#include "analysis/study/session_conditions.h"
#include "core/sim/population.h"
#include "sessions/session_protocol.h"
#include "sessions/study_session.h"
#include "sessions/trial_end.h"
#include "protocols/loop_protections.h"
#include "protocols/protocol_json.h"
#include "protocols/rng.h"

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

// On the virtual clock no watchdog runs (simulated time waits for the
// loop): a device call that has kept the loop from advancing this long in
// wall time is announced as hung. Long against what a loaded machine can
// hold a thread off the CPU, since here nothing real waits on the device.
constexpr double kVirtualClockHang_s = 2.0;

// What the operator does after a device call the session gave up on.
constexpr const char* kHungDeviceAdvice =
    ". The device's code cannot be stopped inside this process: restart the device, then run the session again; "
    "an isolated plugin (docs/devices.md) is killed and restarted instead";

std::string ms_text(double s) { return std::to_string(static_cast<long long>(std::llround(1e3 * s))) + " ms"; }

// One session, stage by stage: opening (StudySession), then per trial the
// training before a task's first trial, the trial itself (the rig, the
// loop's supervision, how it ended), and closing.
class SessionRun {
 public:
  SessionRun(const std::filesystem::path& db_path, const SessionOptions& options, SittingGate gate = {});
  SessionResult run();

 private:
  // What the supervision of a running trial keeps track of.
  struct TrialWatch {
    std::optional<std::string> operator_abort;  // the reason, once the operator aborted this trial
    std::optional<Clock::time_point> hung_since;
    DeviceCall hung_call = DeviceCall::kNone;
    std::uint64_t last_ticks = 0;
    Clock::time_point ticks_moved = Clock::now();
    bool stopped = false;
  };

  std::optional<db::TrialRow> next_trial();
  bool train(const db::TrialRow& trial);
  void run_trial(const db::TrialRow& trial);
  SessionResult run_schedule();
  void supervise(SimRig& rig, std::unique_ptr<SimRig>& rig_owner, const db::TrialRow& trial, TrialWatch& watch,
                 db::TrialOutcome& outcome, std::optional<CrashNote>& crash_note);
  void take_operator_actions(const db::TrialRow& trial, double t_s, TrialWatch& watch, db::TrialOutcome& outcome);
  void watch_for_hang(SimRig& rig, const db::TrialRow& trial, TrialWatch& watch);
  [[noreturn]] void give_up_on_hung_device(HapticLoop& loop, std::unique_ptr<SimRig>& rig_owner,
                                           const db::TrialRow& trial, const TrialWatch& watch,
                                           db::TrialOutcome& outcome, std::optional<CrashNote>& crash_note);
  [[noreturn]] void give_up_on_hung_training(const SimTrialResult& practice, const db::TrialRow& trial,
                                             db::TrainingRow& row, double trained_s, int done);
  SimTrialConfig base_config(const std::string& task, const NamedSettings& settings, std::uint64_t seed,
                             int practice) const;
  [[noreturn]] void refuse(DeviceStatus status, const std::string& what);
  void note_participant_model(SimRig& rig);
  void record_late_operator_aborts();
  void progress(SessionProgress p) const;

  const SessionOptions& options_;
  SittingGate gate_;  // one sitting per session in a group design; its logged override
  StudySession session_;
  db::StudyDb& db_;
  const db::StudyRow& study_;
  SessionResult result_;
  std::uint64_t who_ = 0;
  int training_per_task_ = 0;
  std::int64_t training_setting_ = 0;
  int scheduled_ = 0;
  LoopSafetyConfig protections_;  // the protocol's (protocols/loop_protections.h)
  int watchdog_trips_in_a_row_ = 0;
  Clock::time_point session_start_ = Clock::now();
  std::set<std::string> trained_;
  bool model_noted_ = false;
  std::int64_t last_trial_id_ = 0;  // the last trial run, and its loop time at its end
  double last_trial_end_t_s_ = 0.0;
  double trial_wall_s_ = 0.0;  // wall time of trials finished in this session
  int trials_timed_ = 0;
  std::vector<OperatorEvent> actions_;
};

SessionRun::SessionRun(const std::filesystem::path& db_path, const SessionOptions& options, SittingGate gate)
    : options_(options),
      gate_(std::move(gate)),
      // Opening, the participant's lock, recovery, re-queueing and, once
      // something is to run, the session row: the bookkeeping every runner
      // shares (study_session.h).
      session_(db_path, options.participant, StudySession::DeferBegin{}, refuse_external_ve),
      db_(session_.db()),
      study_(session_.study()) {
  result_.stale_session = session_.stale_session();
  result_.trials_requeued = session_.requeued_on_open();
  result_.nothing_to_run = nothing_to_run(session_, options_.max_trials, result_.staircase);
  if (result_.nothing_to_run) return;  // run() adds no session row
  session_.begin(options.device.describe(), options.clock == ClockKind::kVirtual ? "virtual" : "wall",
                 options.rate_Hz);
  who_ = participant_seed(study_.seed, options_.participant);
  training_per_task_ =
      options_.training_trials.value_or(protocol_training_trials(study_.protocol_json, options_.participant));
  training_setting_ = training_setting_id(db_, study_.id);
  // A staircase adds up to max_trials trials after the schedule: N counts
  // them as the bound they are.
  const std::optional<protocols::StaircaseSpec> staircase_spec =
      protocols::staircase_from_protocol_text(study_.protocol_json, db_.path());
  scheduled_ = session_.scheduled() + (staircase_spec ? staircase_spec->max_trials : 0);
  result_.session_id = session_.session_id();
  if (options_.on_session_opened) options_.on_session_opened(result_.session_id);
  protections_ = protocols::loop_protections_from_protocol_text(study_.protocol_json, db_.path());
  if (gate_.override_detail) {
    db::OperatorActionRow action;
    action.session_id = result_.session_id;
    action.unix_s = db::unix_now_s();
    action.type = "override_due_date";
    action.detail = *gate_.override_detail;
    db_.add_operator_action(action);
  }
}

void SessionRun::progress(SessionProgress p) const {
  if (!options_.on_progress) return;
  p.participant = options_.participant;
  p.trial_count = scheduled_;
  p.elapsed_s = seconds_since(session_start_);
  if (trials_timed_ > 0) p.eta_s = trial_wall_s_ / trials_timed_ * std::max(0, scheduled_ - session_.complete());
  options_.on_progress(p);
}

SimTrialConfig SessionRun::base_config(const std::string& task, const NamedSettings& settings, std::uint64_t seed,
                                       int practice) const {
  SimTrialConfig c;
  c.task = parse_task_kind(task);
  c.device = options_.device;
  c.settings = settings.engine;
  c.participant_seed = who_;
  c.population = options_.population;
  c.trial_seed = seed;
  c.practice_trials = practice;
  c.clock = options_.clock;
  c.rate_Hz = options_.rate_Hz;
  c.realtime = options_.realtime;
  c.max_duration_s = options_.max_trial_s;
  c.safety = protections_;
  return c;
}

// Once per session, when a simulated participant first holds the device:
// the model it was drawn from, with the session (a person at the device
// leaves it NULL). Sessions of one study drawn from different models are
// not comparable; analyze and study show say so.
void SessionRun::note_participant_model(SimRig& rig) {
  if (model_noted_ || rig.participant() == nullptr) return;
  model_noted_ = true;
  db_.set_session_participant_model(result_.session_id, describe_participant_model(options_.population));
}

// The device would not be driven: nothing was started, so the session
// closes with the trial still planned.
void SessionRun::refuse(DeviceStatus status, const std::string& what) {
  session_.end(db::SessionStatus::kInterrupted);
  const std::string device = "the " + options_.device.describe() + " device";
  throw DeviceNotReadyError(
      status == DeviceStatus::kNotCalibrated
          ? "device: " + device + " is not calibrated/homed; calibrate it, then run the session again (" + what +
                " was not started and stays planned)"
          : "device: " + device + " could not be activated (" + to_string(status) + "); fix it, then run the " +
                "session again (" + what + " was not started and stays planned)");
}

// The next planned trial; once the schedule is done, a staircase (if the
// protocol has one) adds its next trial, until its stopping rule ends it.
std::optional<db::TrialRow> SessionRun::next_trial() {
  std::optional<db::TrialRow> next = session_.next_trial();
  if (next) return next;
  std::optional<analysis::StaircaseProgress> staircase;
  try {
    staircase = plan_next_staircase_trial(db_, study_, session_.participant_id());
  } catch (const analysis::StaircaseBaselineError&) {
    // No baseline: the schedule is done and nothing failed, so the session
    // closes normally before the operator is told why.
    session_.end(db::SessionStatus::kClosed);
    throw;
  }
  if (staircase) result_.staircase = staircase;
  if (staircase && !staircase->state.finished) next = session_.next_trial();
  return next;
}

// Training before this session's first trial of a task: unlogged sample by
// sample (it is not analysed); its length and count are kept. False: the
// operator stopped the session meanwhile.
bool SessionRun::train(const db::TrialRow& trial) {
  if (training_per_task_ <= 0 || !trained_.insert(trial.task).second) return true;
  // Taken before the training is announced, so an end the operator gives as
  // soon as it shows counts.
  const int ends_before =
      options_.training_ends != nullptr ? options_.training_ends->load(std::memory_order_acquire) : 0;
  SessionProgress p;
  p.phase = SessionProgress::Phase::kTraining;
  p.trial_number = session_.complete() + 1;
  p.task = trial.task;
  progress(p);
  const NamedSettings control = db_.setting(training_setting_);
  db::TrainingRow row;
  row.session_id = result_.session_id;
  row.task = trial.task;
  row.started_unix_s = db::unix_now_s();
  double trained_s = 0.0;
  int done = 0;
  const auto operator_ended = [&] {
    return options_.training_ends != nullptr &&
           options_.training_ends->load(std::memory_order_acquire) != ends_before;
  };
  for (int k = 0; k < training_per_task_ && !stop_requested(options_) && !(k > 0 && operator_ended()); ++k) {
    SimTrialConfig c = base_config(trial.task, control, training_seed(who_, trial.task, k), k);
    c.publish_samples = false;
    // A stop (the operator's STOP, Ctrl-C) ends the practice trial now, as
    // it ends a trial: the device is at zero force within a drain, not
    // after up to max_trial_s of practice.
    SimTrialSink sink;
    bool alerted = false;
    sink.between_drains = [&](SimRig& rig) {
      // Said while it happens, as in a trial: the operator is near the device.
      if (!alerted && rig.loop().watchdog_tripped() && options_.on_alert) {
        alerted = true;
        options_.on_alert(watchdog_halt_words(rig.device()) + " in the training before trial " +
                          std::to_string(trial.id) + ": " + describe(rig.loop().safety_trip()));
      }
      note_participant_model(rig);
      return !stop_requested(options_);
    };
    sink.device_hang_grace_s = options_.device_hang_grace_s;
    const SimTrialResult practice = run_sim_trial(c, sink);
    if (practice.device_refused) refuse(practice.device_status, "the training for trial " + std::to_string(trial.id));
    if (practice.device_hung) give_up_on_hung_training(practice, trial, row, trained_s, done);
    trained_s += practice.duration_s;
    ++done;
    // Recorded as what it was: a practice trial cut short is not one done.
    if (std::string why = practice_cut_short_reason(practice, options_.max_trial_s); !why.empty()) {
      ++row.cut_short;
      row.cut_short_reason = std::move(why);
    }
  }
  row.ended_unix_s = db::unix_now_s();
  row.duration_s = trained_s;
  row.trials = done - row.cut_short;
  db_.add_training(row);
  result_.training_trials += done;
  result_.training_cut_short += row.cut_short;
  return !stop_requested(options_);
}

// A practice trial's device call that never returned: run_sim_trial left
// the rig to the stuck thread. The training done so far is recorded, the
// session is interrupted, and the process must end (DeviceHungError).
void SessionRun::give_up_on_hung_training(const SimTrialResult& practice, const db::TrialRow& trial,
                                          db::TrainingRow& row, double trained_s, int done) {
  const std::string why = "device " + std::string(to_string(practice.hung_call)) + " hung for " +
                          ms_text(practice.hung_s) + " and had not returned when the session gave up on it";
  row.ended_unix_s = db::unix_now_s();
  row.duration_s = trained_s + practice.duration_s;
  row.cut_short += 1;
  row.cut_short_reason = why;
  row.trials = done - row.cut_short + 1;
  db_.add_training(row);
  session_.end(db::SessionStatus::kInterrupted);
  throw DeviceHungError(why + " (in the training before trial " + std::to_string(trial.id) + ", which stays planned)" +
                        kHungDeviceAdvice);
}

// An abort the operator sent as the session's last trial ended (accepted,
// but after the runner's last poll of it): recorded on the trial it named as
// missed, as one that reaches the next trial is, never dropped.
void SessionRun::record_late_operator_aborts() {
  if (!options_.take_operator_events) return;
  actions_.clear();
  options_.take_operator_events(actions_);
  for (const OperatorEvent& a : actions_) {
    if (!a.abort || a.trial_id == 0) continue;  // the rest is in operator_action already
    db::EventRow e;
    e.trial_id = a.trial_id;
    e.t_s = a.trial_id == last_trial_id_ ? last_trial_end_t_s_ : 0.0;
    e.type = "operator_abort_missed";
    e.detail = "trial " + std::to_string(a.trial_id) + " had ended: " + a.detail;
    db_.add_event(e);
  }
}

// The operator's actions since the last poll go into the trial's record; an
// abort of this trial ends it, one of a trial that has ended is recorded as
// missed.
void SessionRun::take_operator_actions(const db::TrialRow& trial, double t_s, TrialWatch& watch,
                                       db::TrialOutcome& outcome) {
  if (!options_.take_operator_events) return;
  actions_.clear();
  options_.take_operator_events(actions_);
  for (const OperatorEvent& a : actions_) {
    if (a.abort && a.trial_id != 0 && a.trial_id != trial.id) {
      outcome.closing_events.push_back({trial.id, t_s, "operator_abort_missed", -1, 0,
                                        "trial " + std::to_string(a.trial_id) + " had ended: " + a.detail});
      continue;
    }
    outcome.closing_events.push_back({trial.id, t_s, a.type, -1, 0, a.detail});
    if (a.abort && !watch.operator_abort) watch.operator_abort = a.detail;
  }
}

// A device call that does not return: the operator hears of it at once, and
// the lock file says so in case the process is killed now.
void SessionRun::watch_for_hang(SimRig& rig, const db::TrialRow& trial, TrialWatch& watch) {
  HapticLoop& loop = rig.loop();
  const std::uint64_t ticks = loop.ticks();
  if (ticks != watch.last_ticks) {
    watch.last_ticks = ticks;
    watch.ticks_moved = Clock::now();
    // On the virtual clock a call announced as hung that came back was only
    // slow (a loaded machine): the trial goes on as it was.
    if (watch.hung_since && !loop.watchdog_tripped()) {
      watch.hung_since.reset();
      session_.clear_pending_reason();
      if (options_.on_alert)
        options_.on_alert("the device call of trial " + std::to_string(trial.id) + " returned after all; the trial goes on");
    }
  }
  // Once announced, a hang is not announced again -- unless it was the
  // host's (no device call) and a device call now hangs too (deactivate()
  // as the loop ends): that one is what may never return.
  if (watch.hung_since && (watch.hung_call != DeviceCall::kNone || loop.watchdog_call() == DeviceCall::kNone)) return;
  const DeviceCall in_call = loop.device_call().load(std::memory_order_acquire);
  const bool tripped = loop.watchdog_tripped();
  const bool virtual_hang = options_.clock == ClockKind::kVirtual && in_call != DeviceCall::kNone &&
                            seconds_since(watch.ticks_moved) > kVirtualClockHang_s;
  if (!tripped && !virtual_hang) return;
  watch.hung_since = Clock::now();
  watch.hung_call = tripped ? loop.watchdog_call() : in_call;
  const double limit_s = tripped ? loop.watchdog_limit_s() : kVirtualClockHang_s;
  const std::string what = watch.hung_call != DeviceCall::kNone
                               ? "device " + std::string(to_string(watch.hung_call)) + "() has not returned"
                               : std::string("the haptic loop has completed no update");
  // Recorded before it is announced: an operator who kills the session on
  // seeing the alert leaves the cause for the next session to find (in the
  // other order a kill between the two lost it; seen under load in CI).
  if (watch.hung_call != DeviceCall::kNone)
    session_.record_pending_reason("device " + std::string(to_string(watch.hung_call)) + " hung for at least " +
                                   ms_text(limit_s) + " (the session ended before it returned)");
  if (options_.on_alert)
    options_.on_alert(what + " for " + ms_text(limit_s) + (tripped ? "" : " of wall time") + " in trial " +
                      std::to_string(trial.id) + (tripped ? "; " + watchdog_halt_words(rig.device()) : ""));
}

// The loop thread is inside the device's code: record the trial and the
// session from here, and leave the rig to the stuck thread (told to stop,
// should the call ever return).
void SessionRun::give_up_on_hung_device(HapticLoop& loop, std::unique_ptr<SimRig>& rig_owner,
                                        const db::TrialRow& trial, const TrialWatch& watch, db::TrialOutcome& outcome,
                                        std::optional<CrashNote>& crash_note) {
  loop.request_stop();
  const double hung_s = seconds_since(*watch.hung_since) +
                        (options_.clock == ClockKind::kVirtual ? kVirtualClockHang_s : loop.watchdog_limit_s());
  outcome.status = db::TrialStatus::kAborted;
  outcome.abort_reason = "device " + std::string(to_string(watch.hung_call)) + " hung for " + ms_text(hung_s) +
                         " and had not returned when the session gave up on it";
  outcome.dropped_samples = loop.dropped_samples();
  outcome.dropped_events = loop.dropped_events();
  outcome.timing = loop.timing();
  crash_note.reset();
  session_.finish_trial(outcome);
  session_.clear_pending_reason();
  session_.end(db::SessionStatus::kInterrupted);
  (void)rig_owner.release();
  throw DeviceHungError(outcome.abort_reason + " (trial " + std::to_string(trial.id) +
                        ", re-queued with its samples up to the hang)" + kHungDeviceAdvice);
}

// Polls the running loop until it ends: the operator's actions, a hung
// device, the loop's status for the console, and a stop (the operator's,
// an abort, or storage that failed: what the loop produces then is lost,
// so the trial ends rather than running on unrecorded).
void SessionRun::supervise(SimRig& rig, std::unique_ptr<SimRig>& rig_owner, const db::TrialRow& trial,
                           TrialWatch& watch, db::TrialOutcome& outcome, std::optional<CrashNote>& crash_note) {
  HapticLoop& loop = rig.loop();
  for (int polls = 0; loop.running(); ++polls) {
    take_operator_actions(trial, loop.elapsed_s(), watch, outcome);
    watch_for_hang(rig, trial, watch);
    if (watch.hung_since && watch.hung_call != DeviceCall::kNone && loop.running() &&
        loop.ticks() == watch.last_ticks && seconds_since(*watch.hung_since) > options_.device_hang_grace_s)
      give_up_on_hung_device(loop, rig_owner, trial, watch, outcome, crash_note);
    // timing() reads a histogram (~100 µs): every 50th poll, ~100 ms.
    if (options_.on_loop_status && polls % 50 == 0)
      options_.on_loop_status({loop.elapsed_s(), loop.timing(), loop.dropped_samples()});
    if (!watch.stopped && (stop_requested(options_) || watch.operator_abort || session_.writer_failed())) {
      loop.request_stop();
      watch.stopped = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  loop.join();
}

void SessionRun::run_trial(const db::TrialRow& trial) {
  const NamedSettings settings = db_.setting(trial.setting_id);
  const std::uint64_t seed = scheduled_trial_seed(who_, trial, session_.participant_trials());
  SimTrialConfig config = base_config(trial.task, settings, seed,
                                      training_per_task_ + session_.complete_of(trial.task));
  if (options_.configure_trial) options_.configure_trial(config, trial);

  SessionProgress started;
  started.phase = SessionProgress::Phase::kTrialStarted;
  started.trial_number = session_.complete() + 1;
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
  note_participant_model(rig);
  HapticLoop& loop = rig.loop();
  // Powered before the trial is recorded as started, so a device that is
  // not calibrated or homed leaves the trial planned, not aborted.
  if (!loop.activate()) refuse(loop.device_status(), "trial " + std::to_string(trial.id));
  ++result_.trials_run;
  db::TrialOutcome outcome;
  session_.start_trial(trial, loop.samples(), loop.events(), options_.writer);
  // The writer reads the rig's queues: it must stop before the rig goes,
  // also when something below throws.
  struct AbandonOnUnwind {
    StudySession& session;
    ~AbandonOnUnwind() { session.abandon_trial(); }
  } abandon_on_unwind{session_};
  TrialWatch watch;
  take_operator_actions(trial, 0.0, watch, outcome);
  // A crash of this process (an in-process plugin's) leaves its cause in the
  // lock file for the next session's recovery (crash_note.h).
  std::optional<CrashNote> crash_note;
  crash_note.emplace(session_.crash_note_target(), loop, rig.device());
  if (loop.start()) supervise(rig, rig_owner, trial, watch, outcome, crash_note);
  crash_note.reset();
  if (watch.hung_since && watch.hung_call != DeviceCall::kNone) session_.clear_pending_reason();
  // A stall the polls missed (this thread was not scheduled in time): said
  // now, never not at all.
  if (!watch.hung_since && loop.watchdog_tripped() && options_.on_alert)
    options_.on_alert(watchdog_halt_words(rig.device()) + " in trial " + std::to_string(trial.id) + ": " +
                      describe(loop.safety_trip()));
  const TrialEnd end = classify_trial_end(loop, rig.device(), trial.id, watch.operator_abort, options_.max_trial_s,
                                          watchdog_trips_in_a_row_, outcome);
  outcome.dropped_samples = loop.dropped_samples();
  outcome.dropped_events = loop.dropped_events();
  outcome.timing = loop.timing();
  outcome.device_counters = rig.device().counters();
  if (end.stopped_by_operator) result_.stopped_by_operator = true;
  if (end.device_fault) {
    result_.device_fault = true;
    result_.device_fault_reason = end.device_fault_reason;
  }
  // Throws, with the session recorded as interrupted, on a storage failure.
  result_.samples_logged += session_.finish_trial(outcome);
  const double trial_sim_s = loop.elapsed_s();
  last_trial_id_ = trial.id;
  last_trial_end_t_s_ = trial_sim_s;
  trial_wall_s_ += seconds_since(trial_start);
  ++trials_timed_;
  if (outcome.status == db::TrialStatus::kComplete) ++result_.trials_complete;
  else ++result_.trials_aborted;

  SessionProgress finished = started;
  finished.phase = SessionProgress::Phase::kTrialFinished;
  finished.status = outcome.status;
  finished.abort_reason = outcome.abort_reason;
  finished.trial_sim_s = trial_sim_s;
  progress(finished);
}

// A database error between trials (a setting or the protocol edited while
// the session ran, which every read of them refuses; a failing disk) ends
// the session as interrupted before it is reported, rather than leaving it
// open for the next session to recover as a crash.
SessionResult SessionRun::run() {
  if (result_.nothing_to_run) {
    result_.trials_left = session_.trials_left();
    return result_;
  }
  try {
    return run_schedule();
  } catch (const db::DbError&) {
    try {
      session_.end(db::SessionStatus::kInterrupted);
    } catch (const std::exception&) {
      // Already ended (a storage failure ends it itself), or a trial was
      // left running (StudySession::end): the session is left as a crash
      // leaves it, and the participant's next session recovers it. The
      // first error is the one to report.
    }
    throw;
  }
}

SessionResult SessionRun::run_schedule() {
  while (!stop_requested(options_)) {
    if (options_.max_trials && result_.trials_run >= *options_.max_trials) break;
    const std::optional<db::TrialRow> next = next_trial();
    if (!next) break;
    if (gate_.block && next->block != *gate_.block) break;  // one sitting per session
    if (!train(*next)) break;
    if (options_.hold_before_trial) {
      while (!stop_requested(options_) && options_.hold_before_trial())
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      if (stop_requested(options_)) break;
    }
    run_trial(*next);
    if (result_.device_fault) break;
  }
  if (stop_requested(options_)) result_.stopped_by_operator = true;
  record_late_operator_aborts();
  session_.end(result_.device_fault ? db::SessionStatus::kInterrupted : db::SessionStatus::kClosed);
  result_.trials_requeued += session_.requeued();
  result_.trials_left = session_.trials_left();
  result_.condition_warnings = analysis::read_session_conditions(db_, study_.id).warnings;
  return result_;
}

}  // namespace

SessionResult run_session(const std::filesystem::path& db_path, const SessionOptions& options) {
  check_options(options);
  // The device is opened (a plugin loaded, a socket bound) and dropped
  // once before anything is stored, so a wrong path, option or port is
  // refused with nothing changed. Each trial opens it again.
  // A plugin is first tried in a child process, which a crash in its code
  // cannot take this one down with.
  probe_device(options.device, DeviceConfig{options.rate_Hz, 0});
  (void)open_device(options.device);
  SittingGate gate = check_sitting_gate(db_path, options.participant,
                                        options.now_unix_s.value_or(db::unix_now_s()), options.override_due_date);
  return SessionRun(db_path, options, std::move(gate)).run();
}

}  // namespace hapticlab::sessions
