#pragma once
// The option shapes that recur across commands, defined once so that every
// command takes them alike and refuses them with the same words:
//   --rate-hz  a haptic loop rate [Hz], 150..2000
//   --seed     a seed: decimal digits, 0..2^64-1 (its default shown in --help)
//   --jobs,-j  how many at once, 0..256 (0: the command's choice from the cores)
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

CLI::Option* add_loop_rate_option(CLI::App& cmd, double& rate_Hz, const std::string& description);
CLI::Option* add_seed_option(CLI::App& cmd, std::uint64_t& seed, const std::string& description);
CLI::Option* add_jobs_option(CLI::App& cmd, std::size_t& jobs, const std::string& description);

}  // namespace hapticlab::app
