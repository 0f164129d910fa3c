#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {

// `hapticlab stability map`: Table 4.1 for any update rate (issue 19 §2).
void add_stability_command(CLI::App& app);

}  // namespace hapticlab::app
