#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab bench udp [--seconds N] [--rate-hz R] [--port P] [--json]`:
// the UDP bridge's round trip (POLL -> STATE) over loopback at a steady
// rate, against the simulated workstation served in a thread of this
// process (or, with --port, by a running `device serve-sim`).
void add_bench_udp_command(CLI::App& bench);
}  // namespace hapticlab::app
