#pragma once
// The option shapes that recur across commands, defined once so that every
// command takes them alike and refuses them with the same words:
//   --rate-hz  a haptic loop rate [Hz], 150..2000
//   --seed     a seed: decimal digits, 0..2^64-1 (its default shown in --help)
//   --jobs,-j  how many at once, 0..256 (0: the command's choice from the cores)
//   --max-trial-s  a designed trial's time limit [s], 1..3600: a trial that
//              reaches it is aborted for good, so a slip (1e-300, 0.003)
//              would ruin a participant's design
//   --max-trials   how many trials at most, a whole number 0..1000000
// (--population is app/cli/population_option.h.) Each returns its option,
// for a command to add what is its own (capture_default_str, needs, ...).

#include <cstddef>
#include <cstdint>
#include <string>

#include <CLI/CLI.hpp>

namespace hapticlab::app {

// The loop rates the commands accept, and the most jobs at once.
inline constexpr double kMinLoopRate_Hz = 150.0;
inline constexpr double kMaxLoopRate_Hz = 2000.0;
inline constexpr long long kMaxJobs = 256;
// A trial's time limit: a second is shorter than any task; an hour is
// longer than any trial a participant could be kept at.
inline constexpr double kMinTrialLimit_s = 1.0;
inline constexpr double kMaxTrialLimit_s = 3600.0;
inline constexpr long long kMaxTrialsAtMost = 1000000;

CLI::Option* add_loop_rate_option(CLI::App& cmd, double& rate_Hz, const std::string& description);
CLI::Option* add_seed_option(CLI::App& cmd, std::uint64_t& seed, const std::string& description);
CLI::Option* add_jobs_option(CLI::App& cmd, std::size_t& jobs, const std::string& description);
CLI::Option* add_trial_limit_option(CLI::App& cmd, double& max_trial_s, const std::string& description);
CLI::Option* add_max_trials_option(CLI::App& cmd, int& max_trials, const std::string& description);

}  // namespace hapticlab::app
