#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab device serve-sim --port N [--host 127.0.0.1] [--key-file PATH]`: the simulated
// workstation behind the UDP bridge (docs/udp_bridge.md), in this process,
// until SIGINT or SIGTERM. Prints one line once it listens.
void add_device_serve_sim_command(CLI::App& device);
}  // namespace hapticlab::app
