#include "app/cli/population_option.h"
#include "app/study/session_command.h"

#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <optional>
#include <stdexcept>
#include <iostream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "app/cli/cli_checks.h"
#include "app/cli/insecure_flag.h"
#include "app/cli/interrupt_flag.h"
#include "app/cli/progress_line.h"
#include "app/cli/option_shapes.h"
#include "core/device/device_spec.h"
#include "core/loop/realtime.h"
#include "sessions/session_runner.h"

namespace hapticlab::app {
namespace {

constexpr int kMaxTrainingTrials = 1000;

struct SessionCommandOptions {
  std::string db;
  std::string participant;
  std::string device = "sim";
  std::vector<std::string> device_options;
  bool insecure = false;
  std::string clock = "virtual";
  double rate_Hz = 1000.0;
  double max_trial_s = 300.0;
  int training_trials = -1;  // -1: the protocol's
  int max_trials = -1;       // -1: all
  bool blind = false;
  bool training_until_enter = false;
  bool override_due_date = false;
  RealtimeOptions realtime;
  bool json = false;
  std::string population;  // --population (app/cli/population_option.h)
};

// Counts the operator's Enter presses on stdin, for training the operator
// ends. End of input counts once too: nobody is left to press Enter. The
// thread is detached because a read from a terminal cannot be interrupted;
// it blocks harmlessly until the process exits.
void count_enter_presses(std::atomic<int>& presses) {
  std::thread([&presses] {
    for (std::string line; std::getline(std::cin, line);) presses.fetch_add(1, std::memory_order_release);
    presses.fetch_add(1, std::memory_order_release);
  }).detach();
}

std::string trial_label(const sessions::SessionProgress& p, bool blind) {
  std::string s = p.participant + " trial " + std::to_string(p.trial_number) + "/" + std::to_string(p.trial_count) +
                  " " + p.task + " rep " + std::to_string(p.repetition);
  if (!blind) s += " [" + p.setting + "]";
  return s;
}

// HAPTICLAB_TEST_NOW_UNIX_S: seconds since 1970, a finite number.
double parse_test_now(const char* text) {
  char* end = nullptr;
  const double x = std::strtod(text, &end);
  if (end == text || *end != '\0' || !std::isfinite(x) || x < 0)
    throw std::runtime_error(std::string("HAPTICLAB_TEST_NOW_UNIX_S is \"") + text +
                             "\", but must be seconds since 1970 (a number >= 0)");
  return x;
}

// The runner's options from the command's (the --realtime grant is added by run).
sessions::SessionOptions session_options(const SessionCommandOptions& opt) {
  sessions::SessionOptions options;
  options.participant = opt.participant;
  options.device = parse_device_spec(opt.device);
  add_device_options(options.device, opt.device_options);
  options.device.insecure = opt.insecure;
  options.clock = parse_clock_kind(opt.clock);
  options.rate_Hz = opt.rate_Hz;
  options.max_trial_s = opt.max_trial_s;
  // Used when a simulated participant holds the device (sim, or the
  // simulated workstation behind a plugin or the bridge).
  options.population = choose_population(opt.population).point;
  if (opt.training_trials >= 0) options.training_trials = opt.training_trials;
  if (opt.max_trials >= 0) options.max_trials = opt.max_trials;
  options.override_due_date = opt.override_due_date;
  // For tests only (docs/protocols.md): the time due dates are compared with.
  if (const char* now = std::getenv("HAPTICLAB_TEST_NOW_UNIX_S")) options.now_unix_s = parse_test_now(now);
  options.realtime = opt.realtime;
  return options;
}

// --realtime (its grant printed on stderr) and --training-until-enter.
void prepare_session_run(const SessionCommandOptions& opt, sessions::SessionOptions& options) {
  if (opt.realtime.enabled) {
    RealtimeResult granted;
    std::fprintf(stderr, "%s\n", prepare_realtime(opt.realtime, &granted).c_str());
    // Under SCHED_FIFO an isolated plugin costs under 20 µs per update: "plugin:" runs isolated then.
    options.device.realtime_loop = granted.scheduled;
  }
  // Static: the detached reader may outlive this function's frame.
  static std::atomic<int> enter_presses{0};
  if (opt.training_until_enter) {
    if (opt.training_trials < 0) options.training_trials = kMaxTrainingTrials;
    options.training_ends = &enter_presses;
    count_enter_presses(enter_presses);
  }
}

// The progress line of a session: training, each trial started and finished.
std::function<void(const sessions::SessionProgress&)> session_progress(const SessionCommandOptions& opt,
                                                                      ProgressLine& line) {
  return [&opt, &line](const sessions::SessionProgress& p) {
    using Phase = sessions::SessionProgress::Phase;
    const double done = p.trial_count > 0 ? static_cast<double>(p.trial_number - 1) / p.trial_count : 0.0;
    switch (p.phase) {
      case Phase::kTraining:
        line.print(p.participant + ": training (" + p.task + ")" +
                   (opt.training_until_enter ? " - press Enter to end it after the current trial" : ""));
        break;
      case Phase::kTrialStarted:
        line.update(done, trial_label(p, opt.blind), p.elapsed_s, p.eta_s);
        break;
      case Phase::kTrialFinished: {
        char text[96];
        std::snprintf(text, sizeof text, " %s after %.1f s", to_string(p.status), p.trial_sim_s);
        std::string msg = trial_label(p, opt.blind) + text;
        if (!p.abort_reason.empty()) msg += " (" + p.abort_reason + ")";
        line.print(msg);
        break;
      }
    }
  };
}

// The session run; empty (after saying why) when the device was not ready.
// A hung device ends the process with status 3 at once.
std::optional<sessions::SessionResult> run_session_or_refuse(const std::string& db,
                                                             const sessions::SessionOptions& options,
                                                             ProgressLine& line) {
  try {
    return sessions::run_session(db, options);
  } catch (const sessions::DeviceNotReadyError& e) {
    line.finish();
    std::fprintf(stderr, "hapticlab session run: %s\n", e.what());
    return std::nullopt;
  } catch (const sessions::DeviceHungError& e) {
    line.finish();
    std::fprintf(stderr, "hapticlab session run: %s\n", e.what());
    std::fflush(nullptr);
    // A thread is still inside the device's code: ending the process the
    // usual way would wait for it, or destroy what it is using.
    std::_Exit(3);
  }
}

nlohmann::json session_staircase_json(const sessions::SessionResult& r) {
  const auto& st = r.staircase->state;
  nlohmann::json steps = nlohmann::json::array();
  for (const auto& t : st.trials) steps.push_back({{"strength", t.strength}, {"value", t.value}, {"changed", t.changed}});
  return {{"field", r.staircase->spec.field},
          {"measure", r.staircase->spec.measure},
          {"baseline", r.staircase->baseline},
          {"trials", st.trials.size()},
          {"reversals", st.reversal_strengths},
          {"steps", steps},
          {"finished", st.finished},
          {"stop_reason", st.stop_reason},
          {"threshold", st.threshold ? nlohmann::json(*st.threshold) : nlohmann::json()}};
}

void print_session_json(const SessionCommandOptions& opt, const sessions::SessionOptions& options,
                        const sessions::SessionResult& r) {
  nlohmann::json j = {{"session", r.nothing_to_run ? nlohmann::json() : nlohmann::json(r.session_id)},
                      {"nothing_to_run", r.nothing_to_run ? nlohmann::json(*r.nothing_to_run) : nlohmann::json()},
                      {"participant", opt.participant},
                      {"device", options.device.describe()},
                      {"training_trials", r.training_trials},
                      {"training_cut_short", r.training_cut_short},
                      {"trials_run", r.trials_run},
                      {"trials_complete", r.trials_complete},
                      {"trials_aborted", r.trials_aborted},
                      {"trials_requeued", r.trials_requeued},
                      {"trials_left", r.trials_left},
                      {"updates_logged", r.samples_logged},
                      {"stopped_by_operator", r.stopped_by_operator},
                      {"device_fault", r.device_fault ? nlohmann::json(r.device_fault_reason) : nlohmann::json()},
                      {"stale_session", r.stale_session ? nlohmann::json(*r.stale_session) : nlohmann::json()},
                      {"warnings", r.condition_warnings}};
  if (r.staircase) j["staircase"] = session_staircase_json(r);
  std::printf("%s\n", j.dump(2).c_str());
}

void print_session_text(const SessionCommandOptions& opt, const sessions::SessionResult& r) {
  if (r.nothing_to_run) {
    std::printf("%s\n", r.nothing_to_run->c_str());
    if (r.staircase) std::printf("%s\n", analysis::staircase_summary(*r.staircase).c_str());
    return;
  }
  std::printf("session %lld of %s: %d %s run (%d complete, %d aborted), %d re-queued, %d still planned, "
              "%llu updates logged%s\n",
              static_cast<long long>(r.session_id), opt.participant.c_str(), r.trials_run,
              r.trials_run == 1 ? "trial" : "trials", r.trials_complete, r.trials_aborted, r.trials_requeued,
              r.trials_left, static_cast<unsigned long long>(r.samples_logged),
              r.training_trials > 0 ? (", after " + std::to_string(r.training_trials) + " training trial" +
                                       (r.training_trials == 1 ? "" : "s") +
                                       (r.training_cut_short > 0
                                            ? " (" + std::to_string(r.training_cut_short) +
                                                  " cut short before the task was complete)"
                                            : std::string()))
                                          .c_str()
                                    : "");
  if (r.staircase) std::printf("%s\n", analysis::staircase_summary(*r.staircase).c_str());
}

// 3 on a device fault, 130 when the operator stopped it, else 0.
int session_exit_status(const sessions::SessionResult& r) {
  if (r.device_fault) {
    std::fprintf(stderr, "hapticlab session run: %s; the trial is re-queued, run the session again once the "
                         "device works\n", r.device_fault_reason.c_str());
    return 3;
  }
  if (r.stopped_by_operator) {
    std::fprintf(stderr, "hapticlab session run: stopped; run the same command again to continue\n");
    return 130;
  }
  return 0;
}

int run(const SessionCommandOptions& opt) {
  sessions::SessionOptions options = session_options(opt);
  prepare_session_run(opt, options);
  InterruptFlag interrupt;
  options.stop = &interrupt.flag();
  // With --json, stdout carries only the summary object; progress goes to stderr.
  ProgressLine line(opt.json ? stderr : stdout);
  options.on_progress = session_progress(opt, line);
  // At once, not at the end of the trial: the device may be stuck.
  options.on_alert = [&](const std::string& alert) {
    line.finish();
    std::fprintf(stderr, "hapticlab session run: %s\n", alert.c_str());
    std::fflush(stderr);
  };
  const std::optional<sessions::SessionResult> ran = run_session_or_refuse(opt.db, options, line);
  if (!ran) return 3;
  const sessions::SessionResult& r = *ran;
  line.finish();
  if (r.stale_session)
    std::fprintf(stderr, "hapticlab session run: took over the lock of %s's previous session (%s), which had "
                         "ended without releasing it\n",
                 opt.participant.c_str(), r.stale_session->c_str());
  // Told when the mixing happens, not first at the analysis.
  for (const std::string& w : r.condition_warnings) std::fprintf(stderr, "hapticlab session run: warning: %s\n", w.c_str());
  if (opt.json)
    print_session_json(opt, options, r);
  else
    print_session_text(opt, r);
  return session_exit_status(r);
}

// --realtime and its priority and CPU.
void add_realtime_options(CLI::App* cmd, RealtimeOptions& realtime) {
  cmd->add_flag("--realtime", realtime.enabled,
                "Run the haptic loop with SCHED_FIFO, pinned to one CPU, memory locked (for a real device; "
                "if the system refuses, says so and runs without; docs/devices.md)");
  cmd->add_option("--realtime-priority", realtime.priority, "SCHED_FIFO priority with --realtime, 1..99")
      ->check(whole_number_in(1, 99))
      ->capture_default_str();
  cmd->add_option("--realtime-cpu", realtime.cpu, "CPU for the loop with --realtime (-1: the last one)")
      ->capture_default_str();
}

// --device, --device-option, --insecure, --clock, --rate-hz: what runs the trials.
void add_session_device_options(CLI::App* cmd, SessionCommandOptions& o) {
  cmd->add_option("--device", o.device,
                  "Device: sim (the simulated workstation and participant), plugin:PATH.so (a device plugin, "
                  "docs/devices.md), plugin-isolated:PATH.so (the plugin in a process of its own: a crash or hang "
                  "ends the trial, not the session), udp:[HOST:]PORT (a driver behind the UDP bridge, "
                  "docs/udp_bridge.md)")
      ->check([](const std::string& text) {
        try {
          parse_device_spec(text);
          return std::string();
        } catch (const std::invalid_argument& e) {
          return std::string(e.what());
        }
      })
      ->capture_default_str();
  cmd->add_option("--device-option", o.device_options, "key=value passed to the device (repeatable)");
  add_insecure_flag(cmd, o.insecure);
  cmd->add_option("--clock", o.clock, "virtual: as fast as the CPU allows; wall: real time")
      ->check(CLI::IsMember({"virtual", "wall"}))
      ->capture_default_str();
  add_loop_rate_option(*cmd, o.rate_Hz, "Haptic loop rate [Hz], 150..2000")
      ->capture_default_str();
}

// --max-trial-s, --training-trials, --training-until-enter, --max-trials,
// --override-due-date: which trials run, and how long.
void add_session_trial_options(CLI::App* cmd, SessionCommandOptions& o) {
  add_trial_limit_option(*cmd, o.max_trial_s,
                         "Time limit per trial [s], 1..3600; a trial that reaches it is aborted and not re-queued")
      ->capture_default_str();
  cmd->add_option("--training-trials", o.training_trials,
                  "Simulated training trials per task before its first trial, 0..1000 (default: the protocol's; "
                  "with --training-until-enter the most it may last, default 1000)")
      ->check(whole_number_in(0, kMaxTrainingTrials));
  cmd->add_flag("--training-until-enter", o.training_until_enter,
                "The operator ends each task's training: trials repeat until Enter is pressed (or stdin ends), "
                "as with a real participant, who practises until the operator judges them ready");
  add_max_trials_option(*cmd, o.max_trials, "Run at most this many trials, then stop, 0..1000000 (default: all)");
  cmd->add_flag("--override-due-date", o.override_due_date,
                "Run a group design's next sitting before its due date (the protocol's minimum gap); the "
                "override is logged in the study (operator_action)");
}

}  // namespace

void add_session_command(CLI::App& app) {
  CLI::App* session = app.add_subcommand("session", "Run a participant's session of a stored study");
  session->require_subcommand(1);
  auto opt = std::make_shared<SessionCommandOptions>();
  CLI::App* cmd = session->add_subcommand(
      "run",
      "Train, then run the participant's planned trials in schedule order, logging every sample into the "
      "study database. Ctrl-C aborts the running trial (its samples are kept and marked), re-queues it and "
      "closes the session; running the command again continues with the next unfinished trial. "
      "Exit status 0 when done, 130 when stopped, 3 on a device fault, a safety limit or watchdog (docs/safety.md), "
      "or a device that is not calibrated.");
  cmd->add_option("--db", opt->db, "Study database (from `hapticlab study create`)")->required();
  cmd->add_option("--participant", opt->participant, "Participant code, as in the protocol")->required();
  add_population_option(cmd, opt->population);
  add_session_device_options(cmd, *opt);
  add_session_trial_options(cmd, *opt);
  add_realtime_options(cmd, opt->realtime);
  cmd->add_flag("--json", opt->json,
                "Print the session's summary as one JSON object on stdout (progress goes to stderr)");
  cmd->add_flag("--blind", opt->blind,
                "Never print setting names (when the participant can see this terminal)");
  cmd->callback([opt] {
    const int status = run(*opt);
    if (status != 0) throw CLI::RuntimeError(status);
  });
}

}  // namespace hapticlab::app
