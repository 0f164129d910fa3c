#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab engine replay --settings FILE --input FILE.csv --output FILE.csv`
void add_engine_replay_command(CLI::App& engine);
}  // namespace hapticlab::app
