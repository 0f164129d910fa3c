#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// The `device` command group (device serve-sim, device check, ...): created
// on the first call, returned on the next, so each subcommand's file adds
// itself without knowing the others.
CLI::App& device_group(CLI::App& app);
}  // namespace hapticlab::app
