#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab study create --protocol FILE --db FILE.db` and
// `hapticlab study show --db FILE.db [--json] [--schedule]`.
void add_study_command(CLI::App& app);
}  // namespace hapticlab::app
