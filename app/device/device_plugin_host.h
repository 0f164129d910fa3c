#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab device plugin-host --channel-fd N --parent-pid P`, hidden: the
// process an isolated device plugin runs in (core/device/plugin_host.h).
// HapticLab starts it itself; it is not for the operator.
void add_device_plugin_host_command(CLI::App& device);
// Registers this executable as the host of isolated plugins.
void register_plugin_host();
}  // namespace hapticlab::app
