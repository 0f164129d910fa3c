// The recurring option shapes (--rate-hz, --seed, --jobs, --max-trial-s,
// --max-trials), one definition each.
#include "app/cli/option_shapes.h"

#include "app/cli/cli_checks.h"

namespace hapticlab::app {

CLI::Option* add_loop_rate_option(CLI::App& cmd, double& rate_Hz, const std::string& description) {
  return cmd.add_option("--rate-hz", rate_Hz, description)->check(number_in(kMinLoopRate_Hz, kMaxLoopRate_Hz));
}

CLI::Option* add_seed_option(CLI::App& cmd, std::uint64_t& seed, const std::string& description) {
  return cmd.add_option("--seed", seed, description)->capture_default_str()->check(seed_number());
}

CLI::Option* add_jobs_option(CLI::App& cmd, std::size_t& jobs, const std::string& description) {
  return cmd.add_option("--jobs,-j", jobs, description)->check(whole_number_in(0, kMaxJobs));
}

CLI::Option* add_trial_limit_option(CLI::App& cmd, double& max_trial_s, const std::string& description) {
  return cmd.add_option("--max-trial-s", max_trial_s, description)
      ->check(number_in(kMinTrialLimit_s, kMaxTrialLimit_s));
}

CLI::Option* add_max_trials_option(CLI::App& cmd, int& max_trials, const std::string& description) {
  return cmd.add_option("--max-trials", max_trials, description)->check(whole_number_in(0, kMaxTrialsAtMost));
}

}  // namespace hapticlab::app
