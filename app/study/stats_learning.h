#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab stats learning TRIALS.csv --measure M --out DIR [--cusum-criterion X ...]`
// and `hapticlab stats transfer TRIALS.csv --measure M [--control-group G ...]`:
// the learning-curve and transfer analyses of issue 38 on a trial table
// (analysis/learning/trial_table.h). Adds both under `stats`.
void add_stats_learning_commands(CLI::App& stats);
}  // namespace hapticlab::app
