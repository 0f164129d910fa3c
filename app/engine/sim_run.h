#pragma once
#include <atomic>
#include <filesystem>

#include <CLI/CLI.hpp>

#include "core/sim/trial_runner.h"

namespace hapticlab::app {
// Runs the trial and writes every loop update with its events to `output`
// (the `sim run` columns, core/loop/loop_sample_csv.h). The file appears only
// once complete: when `stop` is raised (Ctrl-C, polled between drains) the
// loop stops, stop_reason is kStopRequested and nothing is written (a
// prefix of the trial would read as a whole one). Throws what run_sim_trial
// throws, or for a file that cannot be written.
SimTrialResult run_sim_trial_to_csv(const SimTrialConfig& config, const std::filesystem::path& output,
                                    const std::atomic<bool>& stop);

// Says on stderr that `command` ("sim run") was stopped and that nothing
// was written to `output`; returns 130, the exit status for Ctrl-C.
int report_stopped(const char* command, const SimTrialResult& result, const std::filesystem::path& output);

// `hapticlab sim run --task dissection|clip --settings FILE [--participant-seed N]
//  [--trial-seed N] [--practice N] [--clock virtual|wall] [--rate-hz 1000]
//  [--thesis-rate] [--max-duration-s S] --output FILE.csv`
void add_sim_run_command(CLI::App& sim);
}  // namespace hapticlab::app
