#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `--insecure`, on every command that takes --device: lets the UDP bridge
// run without a key (device-option key_file) to a host outside
// 127.0.0.0/8, which is refused otherwise (docs/udp_bridge.md, "Trust").
inline CLI::Option* add_insecure_flag(CLI::App* cmd, bool& insecure) {
  return cmd->add_flag("--insecure", insecure,
                       "Allow a udp: device beyond loopback without a key (device-option key_file): anyone on the "
                       "network could then forge its readings and commands (docs/udp_bridge.md, \"Trust\")");
}
}  // namespace hapticlab::app
