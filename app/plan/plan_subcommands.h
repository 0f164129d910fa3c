#pragma once
// The subcommands of `hapticlab plan` (plan_command.cc registers them),
// each in its own file: power (plan_power.cc), merge (plan_merge_command.cc)
// and calibrate (plan_calibrate.cc).
#include <CLI/CLI.hpp>

namespace hapticlab::app {

void add_plan_power_subcommand(CLI::App* plan);
void add_plan_merge_subcommand(CLI::App* plan);
void add_plan_calibrate_subcommand(CLI::App* plan);

}  // namespace hapticlab::app
