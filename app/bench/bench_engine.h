#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab bench engine [--json]`: ns per update, thesis Table 2.3 rows.
void add_bench_engine_command(CLI::App& bench);
}  // namespace hapticlab::app
