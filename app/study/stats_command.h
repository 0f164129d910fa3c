#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab stats friedman|pairwise|durbin|skillings-mack|correlation|ks
//  --csv FILE ...`: the analysis library's tests on long-format CSV data.
// Adds the `stats` subcommand to `app`. Errors are thrown as
// std::runtime_error (hapticlab::analysis::DataError) from the callbacks.
void add_stats_command(CLI::App& app);
}  // namespace hapticlab::app
