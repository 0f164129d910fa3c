#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab bench analyze [--dir DIR] [--keep] [--rate-hz R] [--no-plots]
// [--json]`: builds a synthetic thesis-sized study database (135 trials of
// 1-2 minutes at 1 kHz, untimed), then times the full analysis and report.
void add_bench_analyze_command(CLI::App& bench);
}  // namespace hapticlab::app
