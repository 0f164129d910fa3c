#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab export --db FILE.db [--trial N] --format csv --out DIR`: samples
// and events of one trial, or of every started trial of the study plus
// trials.csv (db/export_csv.h). Opens the database read-only and never
// recovers it, so it is safe while a session runs. Errors (missing file,
// unknown trial, unknown format) are thrown as std::runtime_error from the
// callback, naming the value and what is allowed.
void add_export_command(CLI::App& app);
}  // namespace hapticlab::app
