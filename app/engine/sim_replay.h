#pragma once
// `hapticlab sim replay`: a recorded motion through the engine and a task VE.

#include <CLI/CLI.hpp>

namespace hapticlab::app {

void add_sim_replay_command(CLI::App& sim);

}  // namespace hapticlab::app
