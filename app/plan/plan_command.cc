// `hapticlab plan`: registers its subcommands (plan_subcommands.h).
#include "app/plan/plan_command.h"

#include "app/plan/plan_subcommands.h"

namespace hapticlab::app {

void add_plan_measure_option(CLI::App* cmd, std::string& measure) {
  cmd->add_option("--measure", measure, "Measure of the printed table and figures (power.csv has all)")
      ->capture_default_str()
      ->check(CLI::IsMember({"force_median_N", "force_p95_N", "completion_time_s", "speed_median_m_per_s",
                             "path_length_m"}));
}

void add_plan_command(CLI::App& app) {
  CLI::App* plan = app.add_subcommand("plan", "Plan a study before recruiting anyone: simulate it many times");
  plan->require_subcommand(1);
  add_plan_power_subcommand(plan);
  add_plan_merge_subcommand(plan);
  add_plan_calibrate_subcommand(plan);
}

}  // namespace hapticlab::app
