#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab device check --device SPEC [--device-option k=v ...] [--seconds S]
// [--rate-hz R] [--json]`: what a lab runs first on a new device. Opens,
// configures and activates the device, reads it at the loop rate on the
// wall clock for S seconds while commanding zero force, and prints the
// device's name and ratings, the rate achieved, the period's jitter, the
// range each joint moved through, and the faults by status. Exit 0 if the
// device worked throughout, 3 if it refused to start or had any fault.
void add_device_check_command(CLI::App& device);
}  // namespace hapticlab::app
