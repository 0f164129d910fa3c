// The recurring option shapes (--rate-hz, --seed, --jobs), one definition each.
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

}  // namespace hapticlab::app
