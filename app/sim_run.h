#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab sim run --task dissection|clip --settings FILE [--participant-seed N]
//  [--trial-seed N] [--practice N] [--clock virtual|wall] [--rate-hz 1000]
//  [--thesis-rate] [--max-duration-s S] --output FILE.csv`
void add_sim_run_command(CLI::App& sim);
}  // namespace hapticlab::app
