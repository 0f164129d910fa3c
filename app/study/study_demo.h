#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab demo [--out DIR] [--quick]`: the thesis study end to end on the
// simulated rig — design, sessions of every simulated surgeon logged into
// SQLite, analysis, report. Killed halfway, it resumes when run again.
void add_study_demo_command(CLI::App& app);
}  // namespace hapticlab::app
