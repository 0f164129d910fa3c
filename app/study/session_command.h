#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab session run --db FILE.db --participant CODE [--device sim]
//  [--clock wall|virtual] ...`: one participant's session, resumable.
void add_session_command(CLI::App& app);
}  // namespace hapticlab::app
