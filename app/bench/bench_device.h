#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab bench device [--plugin PATH] [--updates N] [--rounds R] [--json]`:
// the device plugin's call overhead. Per update the loop's device calls
// (read, then write) through the built-in sim and through the sim plugin
// (hapticlab_sim_device.so, the same physics behind the C ABI), on the
// virtual clock at 1 kHz; rounds alternate, the best round of each counts;
// the difference is the plugin's overhead per update (issue 15 goal: < 100 ns).
// With --isolation [--period-us P]: the sim plugin in-process against the
// same plugin isolated in its host process (IsolatedPluginDevice), each
// update's read + write timed alone, paced at P on the wall clock as the
// loop paces it, the two alternating; p50/p99/max of each, the difference
// at p99 against issue 33's 20 µs, and the host's CPU use.
void add_bench_device_command(CLI::App& bench);
}  // namespace hapticlab::app
