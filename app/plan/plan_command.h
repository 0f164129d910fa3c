#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {

// `hapticlab plan`: power, merge and calibrate (app/plan/plan_subcommands.h).
void add_plan_command(CLI::App& app);

}  // namespace hapticlab::app
