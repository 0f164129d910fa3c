#pragma once
// The operator console's side of a running session: one participant's
// session (sessions::run_session) on a thread of its own, the operator's
// controls as the runner's hooks, what the pages show, and a decimated copy
// of the samples the writer drains for the live plots. The haptic loop
// never sees any of it: controls are polled by the session thread, samples
// are copied on the writer's thread.

#include <array>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <stdexcept>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "console/console_conflict.h"
#include "console/device_health.h"
#include "console/live_buffer.h"
#include "console/operator_actions.h"
#include "core/device/device_spec.h"
#include "sessions/session_runner.h"

namespace hapticlab::console {

// What STOP found running when it was pressed, for its record.
struct StopSnapshot {
  bool session_running = false;
  std::optional<std::int64_t> session_id;
  std::optional<std::int64_t> trial_id;
  std::optional<double> t_s;
  double unix_s = 0.0;  // when STOP acted (its record keeps this time, however late it is stored)
  std::string what;  // "session S1, trial 4 (id 17)", "session S1, between trials", ""
};

struct ConsoleSessionConfig {
  std::filesystem::path db;
  DeviceSpec device;                // as `session run --device`
  ClockKind clock = ClockKind::kVirtual;
  double rate_Hz = 1000.0;          // the haptic loop's, 150..2000, as `session run --rate-hz`
  double max_trial_s = 300.0;
  std::optional<int> training_trials;  // nullopt: the protocol's
  RealtimeOptions realtime;         // the loop thread's scheduling (core/loop/realtime.h)
  // The population a simulated participant is drawn from, for the sessions
  // and the free trial alike: as `session run --population` (the command
  // reads the fitted population file; core/sim/population.h).
  PopulationParams population;
  double live_rate_Hz = 100.0;      // points kept per instrument and second (the plots draw at >= 30 Hz)
  double live_window_s = 10.0;      // how much the live view keeps
};

// Every control is stored (OperatorActions) before it acts and before the
// console answers; a control that cannot act throws ConsoleConflict (no
// session, no trial) or std::invalid_argument (a bad value), and then
// nothing is stored or done. STOP acts first and is stored after, on a
// connection of its own (`stop_actions`), so neither a control that waits
// nor the control's connection can hold it up.
class ConsoleSession {
 public:
  // `actions`, `stop_actions` (a second connection to the same file) and
  // `device` outlive the session.
  ConsoleSession(ConsoleSessionConfig config, OperatorActions& actions, OperatorActions& stop_actions,
                 DeviceHealth& device);
  ~ConsoleSession();  // stops a running session and waits for it
  ConsoleSession(const ConsoleSession&) = delete;
  ConsoleSession& operator=(const ConsoleSession&) = delete;

  // Starts `participant`'s session; throws ConsoleConflict when one is
  // running or the device hung (device_health.h). `step`: wait for
  // next_trial() before each trial.
  void start(const std::string& participant, bool step);
  // STOP: aborts the trial (re-queued), ends the session. Only sets a flag
  // (the loop thread of the server calls it); returns what ran, which
  // record_stop() then stores.
  StopSnapshot stop();
  // After stop(), once nothing can start another session (the server has
  // stopped): waits for the session's thread, which ends within the device
  // hang grace even when a device call never returns (DeviceHungError).
  void wait_until_ended();
  // Stores STOP's record on its own connection, waiting for another
  // connection's lock as long as the sample writer would (db/sample_writer.h,
  // kBusyPatience); returns "" once stored, else what failed. The status'
  // "last_stop" says meanwhile that it is pending, then stored or failed.
  std::string record_stop(const StopSnapshot& snapshot, const std::string& detail);
  void next_trial();                // lets the next trial start (step mode)
  void set_paused(bool paused);     // holds the session before its next trial (resume also ends a rest)
  // A timed pause: holds the session before its next trial for `seconds`
  // (1..3600, else std::invalid_argument), counted down on the participant
  // screen; the session goes on by itself when it is over, also in step
  // mode (the trial after it starts without "next"). Asked for during a
  // trial, the rest starts when that trial ends.
  void rest(double seconds);
  void end_training();
  // Re-queued; the session goes on. Throws ConsoleConflict when no trial
  // is running, or when `trial_id` (the trial the operator saw; 0: none) is
  // not the one running: it has ended, and the next one is not aborted for it.
  void abort_trial(const std::string& reason, std::optional<std::int64_t> trial_id = std::nullopt);
  // Stored with the running trial, or with the session between trials.
  void note(const std::string& text);

  // The operator's view (includes the setting) and the participant's (no
  // setting, no parameters, nothing that names one).
  nlohmann::json operator_status() const;
  nlohmann::json participant_status() const;
  // Live points of each instrument with loop time > after_t_s.
  std::array<std::vector<LivePoint>, 2> live_since(double after_t_s) const;
  bool running() const;

 private:
  void run(std::string participant);
  // The session runner's hooks (on its thread). Whether the next trial must
  // wait: a rest or step mode holds it; a rest that is over resumes the
  // session, stored as the operator's resume.
  bool hold_before_trial();
  // What the runner reports as trials start and end.
  void on_progress(const sessions::SessionProgress& p);
  // The record of an action now: the session, the running trial and its
  // loop time. Throws ConsoleConflict when no session runs (naming
  // `action`); waits (a few seconds at most) for a session that is starting
  // to have its row. Caller does not hold mutex_.
  db::OperatorActionRow action_row(const char* action, std::string type, std::string detail);
  // Seconds left of a timed rest, nullopt when none runs. Caller holds mutex_.
  std::optional<double> rest_left_s() const;

  const ConsoleSessionConfig config_;
  OperatorActions& actions_;
  OperatorActions& stop_actions_;
  DeviceHealth& device_;
  mutable std::mutex mutex_;  // guards everything below except the atomics
  std::condition_variable opened_;  // session_id_ set, or the session ended
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> paused_{false};
  std::atomic<bool> step_{false};
  std::atomic<int> allowed_trials_{0};  // step mode: trials the operator let start
  std::atomic<int> started_trials_{0};
  std::atomic<int> training_ends_{0};
  std::optional<double> rest_until_wall_s_;  // a timed rest runs until then (steady clock)
  std::optional<double> rest_after_trial_s_;  // asked for during a trial: starts when it ends
  std::vector<sessions::OperatorEvent> pending_actions_;  // aborts, for the runner
  bool running_ = false;
  std::optional<std::int64_t> session_id_;  // once the runner has the session's row
  bool waiting_for_next_ = false;  // step mode: held before a trial until "next"
  std::string participant_;
  std::optional<sessions::SessionProgress> progress_;
  std::optional<sessions::SessionProgress> last_finished_;  // the last trial that ended
  std::optional<sessions::SessionResult> result_;
  std::string error_;
  double trial_started_wall_s_ = 0.0;
  std::optional<sessions::LoopStatus> loop_status_;
  nlohmann::json last_stop_;  // the newest STOP's record: what, and "recorded": "pending"/"stored"/"failed"
  LiveBuffer live_;  // also knows the newest sample the writer drained
};

}  // namespace hapticlab::console
