#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {

// `hapticlab plan power`: simulation-based power of a study design.
void add_plan_command(CLI::App& app);

}  // namespace hapticlab::app
