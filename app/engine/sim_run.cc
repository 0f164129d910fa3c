#include "app/engine/sim_run.h"

#include <cstdio>
#include <string>

#include "app/cli/cli_checks.h"
#include "app/cli/interrupt_flag.h"
#include "app/cli/population_option.h"
#include "app/cli/renamed_option.h"
#include "app/cli/option_shapes.h"
#include "core/loop/loop_sample_csv.h"
#include "core/common/output_file.h"
#include "core/settings/settings_json.h"
#include "core/sim/trial_runner.h"

namespace hapticlab::app {
namespace {

struct SimRunOptions {
  std::string task = "dissection";
  std::string settings;
  std::uint64_t participant_seed = 1;
  std::uint64_t trial_seed = 1;
  int practice = 10;
  std::string clock = "virtual";
  double rate_Hz = 1000.0;
  bool thesis_rate = false;
  double max_duration_s = 300.0;
  std::string output;
  std::string population;  // --population (app/cli/population_option.h)
};

}  // namespace

SimTrialResult run_sim_trial_to_csv(const SimTrialConfig& config, const std::filesystem::path& output,
                                    const std::atomic<bool>& stop) {
  AtomicOutputFile file{output};
  LoopSampleCsvWriter writer(file.stream());
  SimTrialSink sink;
  sink.on_event = [&](const TaskEvent& e) { writer.add_event(e); };
  sink.on_sample = [&](const LoopSample& s) { writer.write(s); };
  sink.between_drains = [&](SimRig&) { return !stop.load(std::memory_order_relaxed); };
  const SimTrialResult r = run_sim_trial(config, sink);
  // Not committed, the file's destructor removes the temporary file.
  if (r.stop_reason != StopReason::kStopRequested) file.commit();
  return r;
}

int report_stopped(const char* command, const SimTrialResult& result, const std::filesystem::path& output) {
  std::fprintf(stderr, "hapticlab %s: stopped by Ctrl-C (or SIGTERM) after %.2f s of the trial; nothing was "
                       "written to %s\n", command, result.duration_s, output.c_str());
  return 130;
}

namespace {

int run(const SimRunOptions& opt) {
  SimTrialConfig config;
  config.task = parse_task_kind(opt.task);
  refuse_output_over_input(opt.settings, opt.output, "--settings", "--out");
  if (!opt.population.empty() && opt.population != "unfitted")
    refuse_output_over_input(opt.population, opt.output, "--population", "--out");
  const NamedSettings settings = load_settings_file(opt.settings);
  config.settings = settings.engine;
  config.participant_seed = opt.participant_seed;
  const ChosenPopulation population = choose_population(opt.population);
  config.population = population.point;
  config.trial_seed = opt.trial_seed;
  config.practice_trials = opt.practice;
  config.clock = parse_clock_kind(opt.clock);
  config.rate_Hz = opt.rate_Hz;
  config.thesis_rate = opt.thesis_rate;
  config.max_duration_s = opt.max_duration_s;

  // Installed before the output's temporary file is made: from then on
  // Ctrl-C stops the loop and the file is removed, rather than the process
  // dying with the temporary file left behind.
  InterruptFlag interrupt;
  const SimTrialResult r = run_sim_trial_to_csv(config, opt.output, interrupt.flag());
  if (r.stop_reason == StopReason::kStopRequested) return report_stopped("sim run", r, opt.output);

  const std::string who = !population.file ? " (unfitted participant model)"
                          : opt.population.empty() ? " (fitted population)"
                                                   : " (population " + opt.population + ")";
  std::printf("%s, %s, participant %llu%s: %s after %.2f s (%s clock), %llu samples, "
              "peak force left %.2f N right %.2f N%s -> %s\n",
              opt.task.c_str(), settings.name.c_str(),
              static_cast<unsigned long long>(opt.participant_seed), who.c_str(),
              r.task_complete ? "complete" : to_string(r.stop_reason), r.duration_s,
              opt.clock.c_str(), static_cast<unsigned long long>(r.samples), r.peak_ve_force_N[0],
              r.peak_ve_force_N[1], r.dropped_samples > 0 ? " (SAMPLES DROPPED)" : "",
              opt.output.c_str());
  if (r.stop_reason == StopReason::kDeviceFault) {
    std::fprintf(stderr, "hapticlab sim run: device fault: %s\n", to_string(r.device_status));
    return 3;
  }
  if (r.stop_reason == StopReason::kSafetyLimit || r.stop_reason == StopReason::kWatchdog) {
    std::fprintf(stderr, "hapticlab sim run: %s: %s (docs/safety.md)\n", to_string(r.stop_reason),
                 describe(r.safety_trip).c_str());
    return 3;
  }
  return r.task_complete ? 0 : 4;
}

}  // namespace

void add_sim_run_command(CLI::App& sim) {
  auto opt = std::make_shared<SimRunOptions>();
  CLI::App* cmd = sim.add_subcommand(
      "run",
      "Run one simulated trial: a simulated participant performs a task on the simulated "
      "workstation through the degradation engine. Writes every loop update to a CSV file and "
      "prints a one-line summary. Exit status 0 when the task completed, 4 when it timed out, "
      "3 on a device fault, 130 when stopped by Ctrl-C (nothing is written then).");
  cmd->add_option("--task", opt->task, "dissection or clip (thesis 3.3.2)")
      ->check(CLI::IsMember({"dissection", "clip"}))
      ->capture_default_str();
  cmd->add_option("--settings", opt->settings, "Engine settings file (examples/settings/*.json)")
      ->required()
      ->check(CLI::ExistingFile);
  add_population_option(cmd, opt->population);
  cmd->add_option("--participant-seed", opt->participant_seed,
                  "Seed of the simulated participant's traits (who performs)")
      ->capture_default_str()
      ->check(seed_number());
  cmd->add_option("--trial-seed", opt->trial_seed,
                  "Seed of this trial: task layout and trial-to-trial variation")
      ->capture_default_str()
      ->check(seed_number());
  cmd->add_option("--practice", opt->practice,
                  "Trials the participant already did (practice makes it faster), >= 0")
      ->check(non_negative_number())
      ->capture_default_str();
  cmd->add_option("--clock", opt->clock,
                  "virtual: as fast as the CPU allows, deterministic; wall: real time")
      ->check(CLI::IsMember({"virtual", "wall"}))
      ->capture_default_str();
  add_loop_rate_option(*cmd, opt->rate_Hz, "Haptic loop rate [Hz], 150..2000")
      ->capture_default_str();
  cmd->add_flag("--thesis-rate", opt->thesis_rate,
                "Let the rate wander between 200 and 2000 Hz like the thesis' VE (overrides --rate-hz)");
  CLI::Option* limit = cmd->add_option("--max-trial-s", opt->max_duration_s,
                                       "Time limit of the trial [s] (simulated time with --clock virtual)")
                           ->check(positive_number())
                           ->capture_default_str();
  add_old_spelling(*cmd, limit, "--max-duration-s", opt->max_duration_s).old->check(positive_number());
  CLI::Option* out = cmd->add_option("--out", opt->output, "CSV file to write (one row per loop update); required");
  const RenamedOption out_option = add_old_spelling(*cmd, out, "--output", opt->output);
  cmd->callback([opt, out_option] {
    out_option.require();
    const int status = run(*opt);
    if (status != 0) throw CLI::RuntimeError(status);
  });
}

}  // namespace hapticlab::app
