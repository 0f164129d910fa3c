#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab bench db [--rate-seconds S] [--size-seconds S] [--loop-seconds S]
// [--dir DIR] [--json]`: the study database's three figures from issue 4:
// sustained logging rate through the SampleWriter (instrument-samples/s),
// database bytes per hour of 2 instruments at 1 kHz, and the wall-clock
// 1 kHz loop's period percentiles with logging off and on, in one run.
void add_bench_db_command(CLI::App& bench);
}  // namespace hapticlab::app
