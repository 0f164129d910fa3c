#pragma once
// The subcommands of `hapticlab plan`, each in its own file: power
// (plan_power.cc), merge (plan_merge_command.cc) and calibrate
// (plan_calibrate.cc); plan_command.cc registers them and defines the
// option they share.
#include <string>

#include <CLI/CLI.hpp>

namespace hapticlab::app {

void add_plan_power_subcommand(CLI::App* plan);
void add_plan_merge_subcommand(CLI::App* plan);
void add_plan_calibrate_subcommand(CLI::App* plan);

// --measure of plan power and plan merge: the measure of the printed table
// and figures (power.csv has every measure).
void add_plan_measure_option(CLI::App* cmd, std::string& measure);

}  // namespace hapticlab::app
