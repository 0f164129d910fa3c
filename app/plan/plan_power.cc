// `hapticlab plan power`: its options, the plan's studies simulated (resumed
// from plan_power.db) with a progress line, then the results written and
// printed (planning/plan_results.h), or a shard's studies stored.
#include "app/plan/plan_subcommands.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

#include <nlohmann/json.hpp>

#include "analysis/report/gnuplot.h"
#include "app/cli/cli_checks.h"
#include "app/cli/interrupt_flag.h"
#include "app/cli/option_shapes.h"
#include "app/cli/population_option.h"
#include "app/cli/progress_line.h"
#include "app/plan/plan_power_options.h"
#include "app/plan/plan_results_print.h"
#include "app/plan/plan_transfer.h"
#include "planning/plan_design.h"
#include "planning/plan_folder.h"
#include "planning/plan_inputs.h"
#include "planning/plan_lock.h"
#include "planning/plan_results.h"
#include "planning/plan_runner.h"
#include "planning/power_store.h"
#include "protocols/protocol_json.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;

// A within-participant plan, checked, before anything is simulated.
struct PowerPlan {
  protocols::Protocol protocol;
  ChosenPopulation population;
  bool model_uncertainty = false;
  planning::SimulatedStudyOptions sim;
  planning::PlanDesign design;
  planning::PlanInputs inputs;
  std::size_t plan_size = 0;  // studies of the whole plan
};

// What this run simulated.
struct PowerRunTally {
  std::size_t total = 0;    // this shard's studies (the plan's without --shard)
  std::size_t already = 0;  // stored before this run
  planning::PlanRunResult ran;
};

std::vector<int> power_plan_counts(const PlanPowerOptions& o, const protocols::Protocol& protocol) {
  std::vector<int> counts = o.participants;
  if (counts.empty()) counts.push_back(static_cast<int>(protocol.participants.size()));
  std::sort(counts.begin(), counts.end());
  counts.erase(std::unique(counts.begin(), counts.end()), counts.end());
  return counts;
}

void check_shard_count(const PlanPowerOptions& o, std::size_t plan_size) {
  if (static_cast<std::size_t>(o.shards) > plan_size)
    throw std::runtime_error("--shard " + std::to_string(o.shard) + "/" + std::to_string(o.shards) + ": the plan has " +
                             std::to_string(plan_size) + " studies (--participants x --studies), so at most " +
                             std::to_string(plan_size) + " shards, each with a study");
}

// The population, the design check (its notes on stderr) and the plan's
// inputs; refuses what does not fit before anything is simulated.
PowerPlan prepare_power_plan(const PlanPowerOptions& o, protocols::Protocol protocol) {
  const std::string protocol_text = protocols::read_protocol_text(o.protocol);
  PowerPlan p;
  p.protocol = std::move(protocol);
  p.population = choose_population(o.population);
  const bool has_draws = p.population.file && !p.population.file->draws.empty();
  if (o.model_uncertainty == "on" && !has_draws)
    throw std::runtime_error("--model-uncertainty on: " + p.population.describe +
                             " has no posterior draws to draw from; use a fitted population file");
  p.model_uncertainty = o.model_uncertainty == "on" || (o.model_uncertainty == "auto" && has_draws);
  p.sim.rate_Hz = o.rate_Hz;
  p.sim.max_trial_s = o.max_trial_s;
  p.sim.population = p.population.point;
  const std::vector<int> counts = power_plan_counts(o, p.protocol);
  p.design = planning::check_plan_design(p.protocol, o.protocol, counts, o.seed, p.sim);
  for (const std::string& note : p.design.notes) std::fprintf(stderr, "note: %s\n", note.c_str());
  p.inputs = planning::plan_inputs(p.protocol, o.protocol, protocol_text, o.seed, counts, o.studies, p.sim);
  p.inputs.population = p.population.key;
  p.inputs.model_uncertainty = p.model_uncertainty;
  p.inputs.shard = o.shard;
  p.inputs.shards = o.shards;
  p.plan_size = p.inputs.studies_of_plan().size();
  check_shard_count(o, p.plan_size);
  if (o.plots) (void)analysis::find_gnuplot();
  return p;
}

void announce_power_run(ProgressLine& line, const PlanPowerOptions& o, const PowerPlan& p, std::size_t todo,
                        std::size_t already, std::size_t total, std::size_t jobs) {
  if (already > 0) line.print(std::to_string(already) + " of " + std::to_string(total) + " studies already in " +
                              (fs::path(o.out) / "plan_power.db").string() + "; continuing");
  line.print("simulating " + std::to_string(todo) + " studies of " + p.protocol.study +
             (o.shards > 1 ? " (shard " + std::to_string(o.shard) + "/" + std::to_string(o.shards) + " of the plan's " +
                                 std::to_string(p.plan_size) + ")"
                           : std::string()) +
             " on " + std::to_string(jobs) + " thread(s), no samples stored; simulated participants from the " +
             p.population.describe +
             (p.model_uncertainty ? ", each study's population drawn from its posterior (model uncertainty on)"
                                  : ", its point estimate (model uncertainty off)"));
}

// The shard's studies not yet in `store`, simulated and stored, with a
// progress line; stops after the running ones on Ctrl-C.
PowerRunTally simulate_power_plan(const PlanPowerOptions& o, const PowerPlan& p, planning::PowerStore& store,
                                  const InterruptFlag& interrupt) {
  const planning::PlanWork work = planning::plan_work(p.inputs, store);
  const std::vector<std::pair<int, int>>& todo = work.todo;
  PowerRunTally t;
  t.total = work.total;
  t.already = work.already;
  ProgressLine line(o.json ? stderr : stdout);
  const std::size_t jobs = planning::plan_jobs(o.jobs, todo.size());
  announce_power_run(line, o, p, todo.size(), t.already, t.total, jobs);
  planning::PlanRunOptions run;
  run.seed = o.seed;
  run.sim = p.sim;
  if (p.model_uncertainty) run.draws = p.population.file->draws;
  run.jobs = jobs;
  run.interrupted = [&] { return interrupt.raised(); };
  run.on_progress = [&](std::size_t stored, double elapsed_s) {
    std::optional<double> eta;
    if (stored > 0) eta = elapsed_s / static_cast<double>(stored) * static_cast<double>(todo.size() - stored);
    line.update(static_cast<double>(t.already + stored) / static_cast<double>(t.total),
                std::to_string(t.already + stored) + "/" + std::to_string(t.total) + " studies" +
                    (interrupt.raised() ? " (stopping after the running ones)" : ""),
                elapsed_s, eta);
  };
  try {
    t.ran = planning::run_plan_studies(p.protocol, todo, store, run);
  } catch (const planning::PlanStoreFailure& e) {
    line.finish();
    throw std::runtime_error(std::string(e.what()) + "; the " + std::to_string(t.already + e.stored) +
                             " studies stored before are kept: free space, then run the same command to resume");
  } catch (...) {
    line.finish();
    throw;
  }
  line.finish();
  return t;
}

// A shard's studies alone are no plan: `plan merge` makes one of all of them.
int print_shard_done(const PlanPowerOptions& o, const PowerRunTally& t, const std::string& did) {
  const std::string store = (fs::path(o.out) / "plan_power.db").string();
  if (o.json) {
    std::printf("%s\n", nlohmann::json{{"shard", o.shard}, {"shards", o.shards}, {"studies", t.total},
                                       {"studies_this_run", t.ran.stored}, {"seconds_this_run", t.ran.elapsed_s},
                                       {"store", store}}
                            .dump(2)
                            .c_str());
  } else {
    std::printf("\nshard %d/%d: %s; all %zu of its studies are in %s. When every shard is done: hapticlab plan "
                "merge SHARD_DIR... --out DIR\n", o.shard, o.shards, did.c_str(), t.total, store.c_str());
  }
  return 0;
}

int run_plan_power(const PlanPowerOptions& o) {
  protocols::Protocol protocol = protocols::load_protocol_file(o.protocol);
  if (const std::optional<int> status = run_if_transfer_design(protocol, o)) return *status;
  const PowerPlan p = prepare_power_plan(o, std::move(protocol));
  planning::prepare_plan_folder(o.out);
  // One run per folder; then the stored plan must be this one, every row checked.
  const planning::PlanLock lock = planning::PlanLock::acquire(o.out);
  planning::PowerStore store(fs::path(o.out) / "plan_power.db", p.inputs, p.protocol);
  InterruptFlag interrupt;
  const PowerRunTally t = simulate_power_plan(o, p, store, interrupt);
  if (interrupt.raised() && t.already + t.ran.stored < t.total) {
    std::fprintf(stderr, "hapticlab plan power: interrupted; %zu of %zu studies are stored in %s. Run the same "
                         "command again to resume.\n", t.already + t.ran.stored, t.total,
                 (fs::path(o.out) / "plan_power.db").c_str());
    return 130;
  }
  char did[160];
  std::snprintf(did, sizeof did, "%zu %s simulated in %.1f s (%.1f million loop updates, none stored)", t.ran.stored,
                t.ran.stored == 1 ? "study" : "studies", t.ran.elapsed_s, static_cast<double>(t.ran.updates) / 1e6);
  std::vector<planning::StudyOutcome> outcomes = store.load(/*complete=*/true);
  if (o.shards > 1) return print_shard_done(o, t, did);
  const planning::PlanResults results =
      planning::write_plan_results(p.protocol, p.inputs, p.design, outcomes, o.out, o.measure, o.plots);
  print_plan_results(p.protocol, p.inputs, p.design, results, o.measure, o.json,
                     {did, t.ran.elapsed_s, t.ran.stored, p.population.describe});
  return 0;
}

// --shard I/N of plan power (a Slurm job array's part of the plan).
void add_shard_option(CLI::App* cmd, PlanPowerOptions& options) {
  PlanPowerOptions* opt = &options;
  cmd->add_option_function<std::string>(
         "--shard",
         [opt](const std::string& v) {
           const auto slash = v.find('/');
           const auto whole = [](const std::string& t, long long lo, long long hi) -> std::optional<int> {
             if (t.empty() || t.size() > 6 || t.find_first_not_of("0123456789") != std::string::npos) return {};
             const long long x = std::stoll(t);
             return x >= lo && x <= hi ? std::optional<int>(static_cast<int>(x)) : std::nullopt;
           };
           const std::optional<int> n = slash == std::string::npos ? std::nullopt : whole(v.substr(slash + 1), 1, 100000);
           const std::optional<int> i = n ? whole(v.substr(0, slash), 0, *n - 1) : std::nullopt;
           if (!i)
             throw CLI::ValidationError("--shard", "'" + v + "' is not I/N with 0 <= I < N <= 100000 (shard I of N, "
                                                   "counting from 0: --shard 0/3, 1/3, 2/3)");
           opt->shard = *i;
           opt->shards = *n;
         },
         "This run's part of the plan, I/N (0 <= I < N): the studies k (the plan's, in order) with k mod N = I, the "
         "same ones a one-machine run simulates, into this --out; `plan merge` joins the N folders. For a Slurm job "
         "array (scripts/slurm/)")
      ->type_name("I/N");
}

// --participants, --studies, --seed, --jobs, --out, --measure: what is simulated and where it goes.
void add_power_plan_options(CLI::App* cmd, PlanPowerOptions& o) {
  cmd->add_option("--protocol", o.protocol, "Protocol file (examples/protocols/*.json)")
      ->required()
      ->check(CLI::ExistingFile);
  add_list_option(*cmd, "--participants", o.participants,
                  "Participant counts to simulate, comma-separated (default: the protocol's), each 1..999",
                  whole_number_in(1, 999));
  cmd->add_option("--studies", o.studies, "Simulated studies per participant count, 1..100000")
      ->capture_default_str()
      ->check(whole_number_in(1, 100000));
  add_seed_option(*cmd, o.seed, "Seed of the whole plan: the same seed gives the same studies");
  add_jobs_option(*cmd, o.jobs, "Studies simulated at once (0: two per core)")->capture_default_str();
  cmd->add_option("--out", o.out, "Folder for plan_power.db (the finished studies), power.csv and figures")
      ->capture_default_str();
  add_plan_measure_option(cmd, o.measure);
}

// --rate-hz, --max-trial-s, --no-plots, --json, --shard, --population,
// --model-uncertainty and the transfer designs' options.
void add_power_run_options(CLI::App* cmd, const std::shared_ptr<PlanPowerOptions>& opt) {
  add_loop_rate_option(*cmd, opt->rate_Hz, "Haptic loop rate of the simulated trials [Hz], 150..2000, as session run's")
      ->capture_default_str();
  add_trial_limit_option(*cmd, opt->max_trial_s, "Per-trial time limit [s], 1..3600, as session run's")
      ->capture_default_str();
  cmd->add_flag("--no-plots", [opt](std::int64_t) { opt->plots = false; }, "No figures (no gnuplot needed)");
  cmd->add_flag("--json", opt->json, "Print the power table as JSON (progress goes to stderr)");
  add_shard_option(cmd, *opt);
  add_population_option(cmd, opt->population);
  cmd->add_option("--model-uncertainty", opt->model_uncertainty,
                  "on: each study draws its participants' population from the fitted population's posterior, and "
                  "power gets a 95 % interval that includes the model's uncertainty beside the simulation-only one; "
                  "off: every study uses the point estimate (default: on when the population is a fitted file)")
      ->check(CLI::IsMember({"on", "off", "auto"}))
      ->capture_default_str();
  add_transfer_options(cmd, *opt);
}

}  // namespace

void add_plan_power_subcommand(CLI::App* plan) {
  auto opt = std::make_shared<PlanPowerOptions>();
  CLI::App* cmd = plan->add_subcommand(
      "power",
      "Simulation-based power: run the protocol's study many times on the simulated rig (virtual clock, fresh "
      "seeds, no samples stored), analyse each the thesis' way, and report how often each setting differs "
      "significantly from the control, per number of participants, with Wilson 95 % intervals. Resumes when "
      "run again with the same --out.");
  add_power_plan_options(cmd, *opt);
  add_power_run_options(cmd, opt);
  cmd->callback([opt, cmd] {
    opt->measure_given = cmd->count("--measure") > 0;
    const int status = run_plan_power(*opt);
    if (status != 0) throw CLI::RuntimeError(status);
  });
}

}  // namespace hapticlab::app
