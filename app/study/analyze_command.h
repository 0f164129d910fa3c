#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab analyze --db FILE.db --out DIR [options]`: the thesis' analysis
// of a study database (analysis/study/study_analysis.h): writes
// DIR/metrics.csv, DIR/report.html, DIR/report.md and DIR/figures/*.svg, and
// prints the headline tables (Tables 3.4-3.6). Errors are thrown as
// std::runtime_error from the callback.
void add_analyze_command(CLI::App& app);
}  // namespace hapticlab::app
