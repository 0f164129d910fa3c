#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab bench loop [--seconds N] [--rate-hz R] [--json]`: the wall-clock
// loop with the full simulated rig; period percentiles and jitter.
// `hapticlab bench sim [--simulated-s S] [--json]`: virtual-clock throughput,
// loop iterations per second with engine, VE and participant running.
void add_bench_loop_commands(CLI::App& bench);
}  // namespace hapticlab::app
