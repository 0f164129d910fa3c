#pragma once
// The console's Tuning page: the thesis' slider window, for pilot work
// outside a study. A free trial runs on the console's device (held by a
// simulated participant on the simulated device, by a person otherwise):
// the task over and over, a new layout each time, until the operator stops
// it. Each slider change is checked against the ranges of docs/settings.md
// (settings_json.h), handed to the engine between two updates, and logged
// (tuning-log.csv); "save" writes a settings file that `hapticlab settings
// check` accepts. Nothing goes into the study database.

#include <array>
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "console/device_health.h"
#include "console/live_buffer.h"
#include "core/loop/rate_monitor.h"
#include "core/sim/trial_runner.h"
#include "core/settings/settings_json.h"

namespace hapticlab::console {

struct ConsoleTuningConfig {
  DeviceSpec device;                      // as the console's sessions
  ClockKind clock = ClockKind::kWall;     // virtual only in tests: it runs as fast as it can
  double rate_Hz = 1000.0;                // 150..2000; the sessions' rate
  RealtimeOptions realtime;
  // The loop's protections, as in the study's sessions: the protocol's
  // force limits and rate tolerance (protocols/loop_protections.h).
  LoopSafetyConfig protections;
  PopulationParams population;            // the pilot participant's, as the sessions' (core/sim/population.h)
  std::filesystem::path out_dir;          // tuning-log.csv and the saved settings files
  double max_s = 3600.0;                  // a free trial stops after this much loop time (> 0)
  // A device call still not returned this long after the loop's watchdog
  // halted the device [s] (> 0): the free trial gives up on it and the
  // device is marked hung (device_health.h), as a session does.
  double device_hang_grace_s = 2.0;
  double live_rate_Hz = 100.0, live_window_s = 10.0;
};

class ConsoleTuning {
 public:
  // `device` (the console's, shared with its sessions) outlives it.
  ConsoleTuning(ConsoleTuningConfig config, DeviceHealth& device);
  ~ConsoleTuning();  // stops a running free trial and waits for it
  ConsoleTuning(const ConsoleTuning&) = delete;
  ConsoleTuning& operator=(const ConsoleTuning&) = delete;

  // Starts a free trial of `task` ("dissection", "clip") from `from`.
  // Throws std::invalid_argument when one runs or the task is unknown,
  // ConsoleConflict when the device hung.
  void start(const std::string& task, const NamedSettings& from);
  void stop();  // zero force (the loop's stop), then the thread ends
  // After stop(), once nothing can start another free trial: waits for it
  // (bounded by the device hang grace, as a session).
  void wait_until_ended();
  bool running() const;

  // Sets one field of the settings, by its path in a settings file:
  // "translation.friction.dynamic_level_N" (a number) or a block's switch,
  // "translation.friction.enabled" (true/false). Throws
  // std::invalid_argument naming the field, the value and the allowed range
  // (docs/settings.md), and then nothing changes; std::runtime_error when
  // the change cannot be written to tuning-log.csv (then it is not made
  // either: the log is the pilot's record); ConsoleConflict (a 409) when no
  // free trial runs: a change before start() would be replaced by its
  // setting, one after the end would be filed under a repetition that never
  // ran with it. save() writes what the last free trial ran with.
  // Logged with the free trial's repetition and the loop time of the newest
  // sample drained when it was handed over: the engine applies it at the
  // start of its next update.
  void set(const std::string& field, const nlohmann::json& value);
  // Writes the settings, named `name`, as out_dir/FILE.json (name: 1..64 of
  // letters, digits, ' ', '_', '-', '+', '.'; FILE is it in lower case with
  // ' ' and '.' as '_', '+' as '-'); returns the file's name. Refuses
  // (std::invalid_argument) a bad name or one already saved.
  std::string save(const std::string& name);

  // running, task, the settings (the file's JSON), the log's newest
  // entries, the saved files, loop timing, an error that ended a trial;
  // while running, loop_t_s (the newest sample drained) and, once no change
  // waits for the loop, applied_t_s (the loop time by which every change so
  // far was in the engine).
  nlohmann::json status() const;
  std::array<std::vector<LivePoint>, 2> live_since(double after_t_s) const;
  // A saved file or the log, for download (served_file.h).
  std::optional<std::filesystem::path> file(const std::string& name) const;

  // Every numeric field with default and range, and the switchable blocks:
  // what the page draws its sliders from.
  static nlohmann::json reference();

 private:
  void run(TaskKind task);
  // Between the loop's drains of free trial `repetition` (on the trial's
  // thread): says a watchdog trip at once, hands the loop the operator's
  // changes, keeps the timing; false when the operator stopped.
  bool poll_free_trial(SimRig& rig, int repetition, int& polls, bool& alerted);
  // The next repetition's trial (its number to `repetition`), or none when
  // the free trial's time is used up.
  std::optional<SimTrialConfig> next_repetition(TaskKind task, int& repetition);
  // Whether the free trial goes on after a repetition that ended so; when
  // not, `error` says why ("" for none).
  bool goes_on_after(const SimTrialResult& r, int repetition, bool alerted, int& host_trips_in_a_row,
                     std::string& error);
  // Appends the entry to tuning-log.csv and log_; returns "" or why the line
  // did not reach the file. `happened`: the entry is of something already
  // done (a start, a watchdog trip, a save), kept in log_ and error_ says
  // the file is incomplete; else (a change not yet made) nothing is kept.
  // Holds mutex_.
  std::string append_log(const std::string& field, const std::string& from, const std::string& to,
                         bool happened = true);

  const ConsoleTuningConfig config_;
  DeviceHealth& device_;
  mutable std::mutex mutex_;  // guards everything below except stop_
  std::thread thread_;
  std::atomic<bool> stop_{false};
  bool running_ = false;
  std::string task_;
  std::string from_name_;               // the setting the trial started from
  nlohmann::json settings_;             // settings_to_json form, as edited
  EngineSettings engine_;               // settings_, parsed and checked
  bool changed_ = false;                // engine_ not yet handed to the running engine
  // Loop time of this repetition by which every change so far was in the
  // engine (read after the hand-over, so the engine had it by the next
  // update or the one after); none while a change waits for the loop, or
  // when nothing was changed.
  std::optional<double> applied_t_s_;
  int free_trial_ = 0;                  // repetitions of the task so far (1-based when running)
  double elapsed_s_ = 0.0;              // loop time of finished repetitions
  LiveBuffer live_;
  nlohmann::json log_ = nlohmann::json::array();  // newest last, at most kLogEntries
  std::vector<std::string> saved_;
  std::string error_;
  std::optional<LoopTimingSummary> last_timing_;
};

}  // namespace hapticlab::console
