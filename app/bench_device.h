#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab bench device [--plugin PATH] [--updates N] [--rounds R] [--json]`:
// the device plugin's call overhead. Per update the loop's device calls
// (read, then write) through the built-in sim and through the sim plugin
// (hapticlab_sim_device.so, the same physics behind the C ABI), on the
// virtual clock at 1 kHz; rounds alternate, the best round of each counts;
// the difference is the plugin's overhead per update (issue 15 goal: < 100 ns).
void add_bench_device_command(CLI::App& bench);
}  // namespace hapticlab::app
