#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab settings check FILE...`: validates settings files and prints
// each one's full, resolved parameters (defaults filled in).
void add_settings_check_command(CLI::App& settings);
}  // namespace hapticlab::app
