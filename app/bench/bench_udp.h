#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab bench udp [--seconds N] [--rate-hz R] [--port P [--host H]] [--key-file F] [--insecure] [--json]`:
// the UDP bridge's round trip (POLL -> STATE) at a steady rate, against the
// simulated workstation served in a thread of this process (or, with
// --port, a running `device serve-sim` or driver), authenticated with the
// key in F if given (the served workstation then uses it too).
void add_bench_udp_command(CLI::App& bench);
}  // namespace hapticlab::app
