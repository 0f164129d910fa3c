#include "app/bench/bench_loop.h"

#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "app/cli/cli_checks.h"
#include "app/cli/data_paths.h"
#include "app/cli/option_shapes.h"
#include "core/loop/realtime.h"
#include "core/loop/stall_probe.h"
#include "core/settings/settings_json.h"
#include "core/sim/trial_runner.h"

namespace hapticlab::app {
namespace {

EngineSettings shipped(const char* name) {
  return load_settings_file(default_settings_dir() / (std::string(name) + ".json")).engine;
}

void bench_wall_loop(double seconds, double rate_Hz, double probe_s, const RealtimeOptions& realtime, bool json) {
  // The machine's own stalls first, on the same clock and core type: a loop
  // cannot beat them, so its jitter is read against them.
  const StallProbeResult probe = probe_s > 0.0 ? probe_stalls(probe_s) : StallProbeResult{};
  const std::string realtime_line = realtime.enabled ? prepare_realtime(realtime) : "real-time: off";
  SimTrialConfig c;
  c.realtime = realtime;
  c.task = TaskKind::kDissection;
  c.settings = shipped("all_degradations");
  c.clock = ClockKind::kWall;
  c.rate_Hz = rate_Hz;
  c.max_duration_s = seconds;
  c.stop_when_complete = false;
  std::uint64_t consumed = 0;
  SimTrialSink sink;
  sink.on_sample = [&](const LoopSample&) { ++consumed; };
  const SimTrialResult r = run_sim_trial(c, sink);
  const LoopTimingSummary& t = r.timing;
  const double nominal_us = 1e6 / rate_Hz;
  // A machine that stalls the loop past the watchdog's limit ends the run
  // early, as it would end a trial (docs/safety.md): the figures cover less.
  if (r.stop_reason == StopReason::kWatchdog || r.stop_reason == StopReason::kSafetyLimit)
    std::fprintf(stderr, "hapticlab bench loop: stopped after %.2f s by the %s: %s\n", r.duration_s,
                 to_string(r.stop_reason), describe(r.safety_trip).c_str());
  if (json) {
    nlohmann::json j = {{"benchmark", "loop"},       {"clock", "wall"},
                        {"rate_Hz", rate_Hz},        {"seconds", seconds},
                        {"updates", t.count},        {"p50_period_us", t.p50_period_s * 1e6},
                        {"p99_period_us", t.p99_period_s * 1e6}, {"max_period_us", t.max_period_s * 1e6},
                        {"mean_period_us", t.mean_period_s * 1e6},
                        {"p99_jitter_us", t.p99_period_s * 1e6 - nominal_us},
                        {"overruns", t.overruns},    {"dropped_samples", r.dropped_samples},
                        {"machine_probe_s", probe_s},
                        {"machine_windows", probe.windows},
                        {"machine_windows_with_stall_over_100us", probe.windows_with_stall},
                        {"machine_max_stall_us", probe.max_stall_s * 1e6},
                        {"realtime", realtime_line}};
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }
  std::printf("hapticlab bench loop: wall clock, %.0f Hz, %.1f s, full simulated rig "
              "(sim device, all degradations, dissection VE, simulated participant, samples queued)\n",
              rate_Hz, seconds);
  std::printf("%s\n", realtime_line.c_str());
  if (probe_s > 0.0) {
    std::printf("machine, before the loop: a bare thread spinning on the clock for %.1f s was stalled > 100 us "
                "in %.2f %% of 1 ms windows (max %.0f us): stalls the loop below cannot avoid\n",
                probe_s, 100.0 * probe.stalled_fraction(), probe.max_stall_s * 1e6);
  }
  std::printf("updates %llu, period p50 %.1f us, p99 %.1f us, max %.1f us, mean %.2f us\n",
              static_cast<unsigned long long>(t.count), t.p50_period_s * 1e6, t.p99_period_s * 1e6,
              t.max_period_s * 1e6, t.mean_period_s * 1e6);
  std::printf("p99 jitter (p99 period - nominal) %.1f us; target < 100 us: %s; overruns %llu; "
              "dropped samples %llu\n",
              t.p99_period_s * 1e6 - nominal_us,
              t.p99_period_s * 1e6 - nominal_us < 100.0 ? "met" : "NOT met",
              static_cast<unsigned long long>(t.overruns),
              static_cast<unsigned long long>(r.dropped_samples));
}

struct SimRow {
  std::string name;
  std::string settings;
  TaskKind task;
  bool publish;
};

// The thesis' settings (Table 3.1) besides the two of the default rows, one
// dissection row each: what a study actually runs.
constexpr const char* kOtherThesisSettings[] = {"no_force_feedback", "friction",         "cogging",
                                                "inertia",           "inertia_backlash", "force_saturation"};

void bench_virtual(double simulated_s, bool every_setting, bool json) {
  std::vector<SimRow> rows = {
      {"dissection, high fidelity, no logging", "high_fidelity", TaskKind::kDissection, false},
      {"dissection, all degradations, no logging", "all_degradations", TaskKind::kDissection, false},
      {"clip, all degradations, no logging", "all_degradations", TaskKind::kClip, false},
      {"dissection, all degradations, samples queued", "all_degradations", TaskKind::kDissection, true},
  };
  if (every_setting) {
    for (const char* s : kOtherThesisSettings)
      rows.push_back({std::string("dissection, ") + s + ", no logging", s, TaskKind::kDissection, false});
  }
  nlohmann::json out = nlohmann::json::array();
  if (!json)
    std::printf("hapticlab bench sim: virtual clock, 1 kHz, %.0f s simulated per row "
                "(engine + VE + participant + sim device)\n%-48s %12s %12s\n",
                simulated_s, "row", "updates/s", "x realtime");
  for (const SimRow& row : rows) {
    SimTrialConfig c;
    c.task = row.task;
    c.settings = shipped(row.settings.c_str());
    c.max_duration_s = simulated_s;
    c.stop_when_complete = false;
    c.publish_samples = row.publish;
    std::uint64_t consumed = 0;
    SimTrialSink sink;
    if (row.publish) sink.on_sample = [&](const LoopSample&) { ++consumed; };
    const auto t0 = std::chrono::steady_clock::now();
    const SimTrialResult r = run_sim_trial(c, sink);
    const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const double updates = static_cast<double>(r.timing.count + 1);
    const double rate = updates / wall_s;
    if (json) {
      out.push_back({{"row", row.name}, {"settings", row.settings}, {"updates", updates}, {"wall_s", wall_s},
                     {"updates_per_s", rate}, {"realtime_factor", r.duration_s / wall_s}});
    } else {
      std::printf("%-48s %12.0f %12.0f\n", row.name.c_str(), rate, r.duration_s / wall_s);
    }
  }
  if (json) std::printf("%s\n", nlohmann::json{{"benchmark", "sim"}, {"rows", out}}.dump(2).c_str());
  else std::printf("target >= 1,000,000 updates/s\n");
}

}  // namespace

void add_bench_loop_commands(CLI::App& bench) {
  struct LoopOpts {
    double seconds = 10.0;
    double rate_Hz = 1000.0;
    double probe_s = 5.0;
    bool json = false;
    RealtimeOptions realtime;
  };
  auto lo = std::make_shared<LoopOpts>();
  CLI::App* loop = bench.add_subcommand(
      "loop", "Run the wall-clock haptic loop with the full simulated rig and report period "
              "percentiles (p50/p99/max), jitter and overruns");
  loop->add_option("--seconds", lo->seconds, "How long to run [s]")
      ->check(number_in(0.5, 3600.0))
      ->capture_default_str();
  add_loop_rate_option(*loop, lo->rate_Hz, "Loop rate [Hz], 150..2000")
      ->capture_default_str();
  loop->add_option("--probe-s", lo->probe_s,
                   "Before the loop, spin a bare thread this long [s] and report how often the machine "
                   "itself stalled it > 100 us (0: skip)")
      ->check(number_in(0.0, 600.0))
      ->capture_default_str();
  loop->add_flag("--realtime", lo->realtime.enabled,
                 "SCHED_FIFO, CPU affinity and locked memory for the loop, as `session run --realtime`");
  loop->add_option("--realtime-priority", lo->realtime.priority, "SCHED_FIFO priority, 1..99")
      ->check(whole_number_in(1, 99))
      ->capture_default_str();
  loop->add_option("--realtime-cpu", lo->realtime.cpu, "CPU for the loop (-1: the last one)")->capture_default_str();
  loop->add_flag("--json", lo->json, "Machine-readable output");
  loop->callback([lo] { bench_wall_loop(lo->seconds, lo->rate_Hz, lo->probe_s, lo->realtime, lo->json); });

  struct SimOpts {
    double simulated_s = 60.0;
    bool every_setting = false;
    bool json = false;
  };
  auto so = std::make_shared<SimOpts>();
  CLI::App* sim = bench.add_subcommand(
      "sim", "Virtual-clock throughput: loop updates per second with engine, VE and simulated "
             "participant running");
  sim->add_option("--simulated-s", so->simulated_s, "Simulated seconds per row")
      ->check(number_in(1.0, 3600.0))
      ->capture_default_str();
  sim->add_flag("--every-setting", so->every_setting,
                "Also one dissection row for each other thesis setting (Table 3.1)");
  sim->add_flag("--json", so->json, "Machine-readable output");
  sim->callback([so] { bench_virtual(so->simulated_s, so->every_setting, so->json); });
}

}  // namespace hapticlab::app
