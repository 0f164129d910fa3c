#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab engine demo`: a short engine demonstration over the thesis'
// eight settings (one scripted motion, one CSV per setting).
void add_engine_demo_command(CLI::App& engine);
}  // namespace hapticlab::app
