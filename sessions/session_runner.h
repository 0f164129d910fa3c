#pragma once
// Runs one participant's session on the rig: training, then the planned
// trials in schedule order, each logged sample by sample into the study
// database, until the schedule is done, the operator stops, or the device
// fails.
//
// Resumption is a property of the database, not of this process: trials are
// taken with StudyDb::next_planned_trial, and opening the file marks a trial
// left 'running' by a crashed runner as aborted. Every aborted trial
// (interrupted, stopped by the operator, device fault) is re-queued as a
// new planned copy at the same schedule position, so running the session
// again continues with the first unfinished trial and never repeats a
// complete one. A trial that hits the time limit is aborted and its slot
// is not re-queued, even if an earlier attempt at that slot had been
// killed or stopped: running it again would most likely time out again.
//
// Seeds (simulated participants): sessions/trial_seeds.h. The same
// database and protocol give the same session, interrupted or not.

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "analysis/study/staircase_progress.h"
#include "core/device/device_spec.h"
#include "core/loop/loop_timing.h"
#include "core/sim/trial_runner.h"
#include "db/sample_writer.h"
#include "db/study_db.h"
#include "sessions/trial_seeds.h"

namespace hapticlab::sessions {

// What the terminal shows while a session runs. `setting` is for the
// operator only; a view the participant can see must not print it.
struct SessionProgress {
  enum class Phase : std::uint8_t { kTraining, kTrialStarted, kTrialFinished };
  Phase phase = Phase::kTrialStarted;
  std::string participant;
  int trial_number = 0;   // k: 1-based, counting this participant's complete trials + 1
  std::int64_t trial_id = 0;  // the trial's id in the database (0 in training)
  int trial_count = 0;    // N: trials in the participant's schedule
  std::string task;
  std::string setting;    // operator view only
  int repetition = 0;
  db::TrialStatus status = db::TrialStatus::kRunning;  // kTrialFinished: complete or aborted
  std::string abort_reason;
  double trial_sim_s = 0.0;  // loop time of the finished trial [s]
  double elapsed_s = 0.0;    // wall time since the session started [s]
  std::optional<double> eta_s;  // wall time left, once a trial has finished in this session
};

// An operator's action during a session (the console's buttons), logged as
// an event of the trial it happens in, at the loop time the runner sees it
// (or at 0 of the next trial when it came between trials). `abort` ends the
// running trial as aborted with `detail` as its reason; it is re-queued and
// the session goes on.
//
// An abort names the trial it is meant for (`trial_id`, 0: whichever
// runs): one that reaches the runner after that trial ended is not applied
// to the next, which the operator never saw; it is logged there as
// "operator_abort_missed", naming the trial it was for.
struct OperatorEvent {
  std::string type;    // event type, e.g. "operator_note", "operator_pause"
  std::string detail;  // free text (the note, the abort reason)
  bool abort = false;
  std::int64_t trial_id = 0;
};

// How the running trial's loop is doing, for a monitor (the console's live
// page): taken on the session's thread about every 100 ms.
struct LoopStatus {
  double elapsed_s = 0.0;            // loop time of the trial
  LoopTimingSummary timing;          // periods so far (core/loop/loop_timing.h)
  std::uint64_t dropped_samples = 0;  // the queue to the writer was full
};

struct SessionOptions {
  std::string participant;  // code, as in the protocol
  DeviceSpec device;  // core/device/device_spec.h; default: the built-in simulated workstation
  ClockKind clock = ClockKind::kVirtual;
  double rate_Hz = 1000.0;     // 150..2000
  RealtimeOptions realtime;    // the loop thread's scheduling (core/loop/realtime.h)
  double max_trial_s = 300.0;  // per-trial time limit (> 0)
  // Simulated training trials per task before the first scheduled trial of
  // that task in this session; nullopt: the protocol's training_trials.
  std::optional<int> training_trials;
  // Training the operator ends, as with a real participant, who practises
  // until the operator judges them ready: when set, each task's training
  // repeats trials until this counter has moved on from its value when the
  // training started (e.g. the operator pressed Enter), checked after each
  // trial, so at least one trial runs. training_trials (or the protocol's)
  // still caps it. May be null: then training is the fixed number of trials.
  const std::atomic<int>* training_ends = nullptr;
  // Run at most this many scheduled trials, then close the session (the
  // rest stays planned). nullopt: the whole remaining schedule.
  std::optional<int> max_trials;
  // A between-group design (sessions/sitting_gate.h): run the next sitting
  // even before it is due, logging the override in operator_action.
  bool override_due_date = false;
  // The time a sitting's due date is compared with [s since 1970, UTC];
  // nullopt: the wall clock. Tests set it to move days forward.
  std::optional<double> now_unix_s;
  // Set (e.g. by a SIGINT handler) to stop: the running trial is aborted
  // and re-queued, and the session closes. May be null.
  const std::atomic<bool>* stop = nullptr;
  std::function<void(const SessionProgress&)> on_progress;
  // Called once the session's row exists (before training and the first
  // trial), with its id: a monitor stores its records under it. May be null.
  std::function<void(std::int64_t session_id)> on_session_opened;
  // Operator controls, both called on the session's thread and may be null.
  // hold_before_trial: polled every 20 ms before each scheduled trial while
  // it returns true (a paused session, or one that waits for "next trial");
  // `stop` still ends the wait. take_operator_events: moves the actions
  // taken since the last call into its argument; polled every 2 ms during a
  // trial and once before it.
  std::function<bool()> hold_before_trial;
  std::function<void(std::vector<OperatorEvent>&)> take_operator_events;
  std::function<void(const LoopStatus&)> on_loop_status;  // may be null
  // Something the operator must hear of at once, while the trial still
  // runs: "device read() has not returned for 20 ms; the watchdog halted
  // the device (zero force)". On the session's thread; may be null.
  std::function<void(const std::string&)> on_alert;
  // How long a device call that does not return is waited for after the
  // alert before the session gives up on it (DeviceHungError) [s], > 0.
  double device_hang_grace_s = 2.0;
  // The population a simulated participant is drawn from (the commands read
  // the fitted population file; core/sim/population.h).
  PopulationParams population;
  // For tests: adjusts a trial's rig configuration (e.g. injects a fault).
  std::function<void(SimTrialConfig&, const db::TrialRow&)> configure_trial;
  db::SampleWriterConfig writer;
};

struct SessionResult {
  std::int64_t session_id = 0;
  int training_trials = 0;   // simulated training trials run
  int training_cut_short = 0;  // of those, ended before the task was complete (training.cut_short)
  int trials_run = 0;        // scheduled trials started in this session
  int trials_complete = 0;
  int trials_aborted = 0;
  int trials_requeued = 0;   // includes trials found aborted on opening
  int trials_left = 0;       // planned trials of this participant after the session
  bool stopped_by_operator = false;
  bool device_fault = false;
  std::string device_fault_reason;
  std::uint64_t samples_logged = 0;  // instrument updates (LoopSamples) stored
  // The participant's staircase (protocol "staircase") as it stood when the
  // session last planned from it: finished, with its threshold, once the
  // stopping rule is met.
  std::optional<analysis::StaircaseProgress> staircase;
  // Set when this participant's previous session had died without
  // releasing its lock (killed, crashed): who it was, for the operator.
  std::optional<std::string> stale_session;
  // The study's sessions now differ in the loop's rate or in who held the
  // device (this session ran otherwise than earlier ones): one warning per
  // difference, naming values and sessions (analysis/study/session_conditions.h).
  std::vector<std::string> condition_warnings;
  // Set when nothing was to run (the participant's schedule and staircase
  // done, or max_trials 0): why, with the participant's counts
  // (nothing_to_run.h). No session row was added: session_id is 0.
  std::optional<std::string> nothing_to_run;
};

// The device refused to be driven when a trial (or training) was about to
// start: not calibrated or homed (DeviceStatus::kNotCalibrated), or it
// would not activate at all. Nothing was started for that trial, which
// stays planned; the session was closed as interrupted. what() tells the
// operator what to do.
class DeviceNotReadyError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A device call (read or write) did not return, even after the watchdog
// halted the device and device_hang_grace_s passed. The trial was recorded
// as aborted ("device read hung for N ms ...", samples up to the hang kept,
// re-queued) and the session closed as interrupted; but the haptic loop's
// thread is still inside the device's code and cannot be stopped, so the
// process must end without waiting for it (the command exits with 3).
// Only in-process plugins can do this; an isolated one is killed instead.
class DeviceHungError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Opens (and recovers) the database, takes the participant's SessionLock
// (db/session_lock.h), runs the session, returns what happened. Throws
// std::invalid_argument for bad options (naming them), db::SessionBusyError
// when the participant has a live session elsewhere (naming its pid),
// std::runtime_error for an unknown participant or a database without a
// study, DeviceNotReadyError when the device refuses to activate, db::DbError
// for a database failure, DeviceHungError (above).
SessionResult run_session(const std::filesystem::path& db_path, const SessionOptions& options);


}  // namespace hapticlab::sessions
