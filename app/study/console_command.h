#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab console --db STUDY.db [--port 8080] [--bind ADDR --token-file F]`:
// the operator's web console (docs/console.md).
void add_console_command(CLI::App& app);
}  // namespace hapticlab::app
