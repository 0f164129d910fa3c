#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab demo`: for now a short engine demonstration over the thesis'
// eight settings (the full study demo replaces it later).
void add_demo_command(CLI::App& app);
}  // namespace hapticlab::app
