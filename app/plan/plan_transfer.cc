#include "app/plan/plan_transfer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <nlohmann/json.hpp>

#include "analysis/stats/data_error.h"
#include "analysis/transfer/group_permutation.h"
#include "app/cli/population_option.h"
#include "core/common/csv_format.h"
#include "core/common/output_file.h"
#include "planning/plan_inputs.h"
#include "planning/transfer_plan.h"
#include "planning/transfer_power.h"
#include "protocols/loop_protections.h"
#include "protocols/protocol_json.h"
#include "planning/plan_folder.h"

namespace hapticlab::app {
namespace {

// The p value of the exact two-group rank test; NaN when a group is empty.
double rank_test_p(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.empty() || b.empty()) return std::numeric_limits<double>::quiet_NaN();
  return analysis::transfer::group_permutation_test({a, b}).p_value;
}

std::vector<int> default_group_sizes(const protocols::Protocol& protocol) {
  const std::size_t groups = protocol.transfer->groups.size();
  return {std::max(1, static_cast<int>(protocol.participants.size() / groups))};
}

struct TaskPower {
  std::string task;
  planning::TransferPower power;
};

std::string power_csv(const std::vector<TaskPower>& tasks, double share) {
  std::ostringstream csv;
  csv << "task,participants_per_group,test,group,reference,studies,significant,power,power_low,power_high,"
         "median_effect_s,force_free_share\n";
  for (const TaskPower& t : tasks) {
    for (const planning::TransferPowerRow& r : t.power.rows) {
      csv << t.task << ',' << r.per_group << ',' << r.test << ',' << csv_text(r.group) << ','
          << csv_text(r.reference) << ',' << r.studies << ',' << r.significant << ',' << format_number(r.power) << ','
          << format_number(r.power_low) << ',' << format_number(r.power_high) << ','
          << format_number(r.median_effect_s) << ',' << format_number(share) << '\n';
    }
  }
  return csv.str();
}

void print_table(const std::vector<TaskPower>& tasks, double share, int studies, const std::string& population) {
  std::printf("Transfer design: power of the post-test and retention comparisons, each group against '%s', on the "
              "change of trial time from the pre-test (exact rank test, alpha 0.05), %d simulated studies per size.\n"
              "Model: %s, its point estimate (a transfer design's studies do not sample the model's uncertainty, "
              "so the intervals below are the simulation's alone); learning from force information with "
              "force_free_share %.2f, an assumption, not a fit "
              "(docs/simulation.md, \"Simulated learners\").\n\n",
              tasks.front().power.rows.empty() ? "" : tasks.front().power.rows.front().reference.c_str(), studies,
              population.c_str(), share);
  std::printf("| task | per group | test | group | power [95 %% CI] | median effect [s] |\n| --- | ---: | --- | --- | --- | ---: |\n");
  for (const TaskPower& t : tasks) {
    for (const planning::TransferPowerRow& r : t.power.rows) {
      std::printf("| %s | %d | %s | %s | %.0f %% [%.0f, %.0f] | %+.2f |\n", t.task.c_str(), r.per_group, r.test.c_str(),
                  r.group.c_str(), 100.0 * r.power, 100.0 * r.power_low, 100.0 * r.power_high, r.median_effect_s);
    }
  }
}

std::string power_json(const std::vector<TaskPower>& tasks, double share) {
  nlohmann::json rows = nlohmann::json::array();
  for (const TaskPower& t : tasks) {
    for (const planning::TransferPowerRow& r : t.power.rows) {
      rows.push_back({{"task", t.task}, {"participants_per_group", r.per_group}, {"test", r.test}, {"group", r.group},
                      {"reference", r.reference}, {"studies", r.studies}, {"significant", r.significant},
                      {"power", r.power}, {"power_low", r.power_low}, {"power_high", r.power_high},
                      {"median_effect_s", r.median_effect_s}});
    }
  }
  return nlohmann::json{{"force_free_share", share}, {"model_uncertainty", false}, {"rows", rows}}.dump(2) + "\n";
}

// transfer_power.inputs.json: what the table was made from (the protocol's
// and settings' hashes, the options, the population, the software).
void write_transfer_inputs(const protocols::Protocol& protocol, const PlanPowerOptions& o,
                           const planning::TransferPowerOptions& options, const std::string& population_key) {
  planning::SimulatedStudyOptions sim;
  sim.rate_Hz = options.simulation.rate_Hz;
  sim.max_trial_s = options.simulation.max_trial_s;
  sim.analysis.alpha = options.alpha;
  planning::PlanInputs inputs = planning::plan_inputs(protocol, o.protocol, protocols::read_protocol_text(o.protocol),
                                                      options.seed, options.per_group, options.studies, sim);
  inputs.population = population_key;
  planning::write_inputs_record(std::filesystem::path(o.out) / "transfer_power.inputs.json", inputs,
                                {{"design", "transfer"},
                                 {"participants_are", "per group"},
                                 {"force_free_share", options.simulation.learning.force_free_share}});
}

}  // namespace

int run_transfer_power(const protocols::Protocol& protocol, const PlanPowerOptions& o) {
  const std::vector<planning::TransferDesign> designs = planning::transfer_designs(protocol);
  const ChosenPopulation population = choose_population(o.population);
  planning::TransferPowerOptions options;
  const double share = o.force_free_share.value_or(0.5);
  options.per_group = o.participants.empty() ? default_group_sizes(protocol) : o.participants;
  // Each size once, in increasing order, as the within-participant plan
  // (plan_inputs): "--participants 3,3" is one size, not two rows of it.
  std::sort(options.per_group.begin(), options.per_group.end());
  options.per_group.erase(std::unique(options.per_group.begin(), options.per_group.end()), options.per_group.end());
  options.studies = o.studies;
  options.seed = o.seed;
  options.jobs = o.jobs > 0 ? static_cast<int>(o.jobs) : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  options.simulation.rate_Hz = o.rate_Hz;
  options.simulation.max_trial_s = o.max_trial_s;
  options.simulation.population = population.point;
  options.simulation.learning.force_free_share = share;
  options.simulation.protections = protocols::loop_protections(protocol);
  planning::prepare_plan_folder(o.out);
  std::vector<TaskPower> tasks;
  int timed_out = 0, trials = 0;
  for (const planning::TransferDesign& d : designs) {
    std::fprintf(stderr, "simulating %s: %d studies per group size...\n", d.task.c_str(), o.studies);
    tasks.push_back({d.task, planning::transfer_power(d, options, rank_test_p)});
    timed_out += tasks.back().power.trials_timed_out;
    trials += tasks.back().power.trials_run;
  }
  write_file_atomically(std::filesystem::path(o.out) / "transfer_power.csv", power_csv(tasks, share));
  write_transfer_inputs(protocol, o, options, population.key);
  if (o.json) std::fputs(power_json(tasks, share).c_str(), stdout);
  else print_table(tasks, share, o.studies, population.describe);
  std::fprintf(o.json ? stderr : stdout,
               "\n%d of %d simulated trials timed out (left out: a participant without a complete test trial is not "
               "compared).\nAll rows: %s\n",
               timed_out, trials, (std::filesystem::path(o.out) / "transfer_power.csv").c_str());
  return 0;
}

std::optional<int> run_if_transfer_design(const protocols::Protocol& protocol, const PlanPowerOptions& o) {
  if (!protocol.transfer) {
    if (o.force_free_share)
      throw std::runtime_error("--force-free-share: only for a protocol with groups (a transfer design); within-"
                               "participant predictions use the fitted model, in which every trial counts fully");
    return std::nullopt;
  }
  auto refuse = [](const std::string& option, const std::string& why) {
    throw std::runtime_error(option + ": not for a protocol with groups (a transfer design): " + why);
  };
  if (o.shards > 1) refuse("--shard", "run its plan on one machine");
  if (o.model_uncertainty == "on") refuse("--model-uncertainty on", "its studies use the population's point estimate");
  if (o.measure_given) refuse("--measure", "a transfer design is compared on trial time");
  return run_transfer_power(protocol, o);
}

void add_transfer_options(CLI::App* cmd, PlanPowerOptions& o) {
  cmd->add_option_function<double>(
         "--force-free-share", [&o](double v) { o.force_free_share = v; },
         "Transfer designs (protocols with groups): the share of a practice trial that counts whatever force the "
         "hand felt, 0..1; the rest counts by the trial's force information (docs/simulation.md, \"Simulated "
         "learners\": an assumption, not a fit; default 0.5)")
      ->check(CLI::Range(0.0, 1.0));
}

}  // namespace hapticlab::app
