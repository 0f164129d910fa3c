#pragma once
// The options of `hapticlab plan power` (app/plan/plan_power.cc), shared
// with its transfer-design path (plan_transfer.h).
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace hapticlab::app {

struct PlanPowerOptions {
  std::string protocol;
  std::vector<int> participants;
  int studies = 200;
  std::uint64_t seed = 1;
  std::size_t jobs = 0;
  std::string out = "plan-power";
  std::string measure = "force_p95_N";
  double rate_Hz = 1000.0;
  double max_trial_s = 300.0;
  bool plots = true;
  bool json = false;
  int shard = 0;   // --shard I/N
  int shards = 1;
  std::string population;                 // --population (app/cli/population_option.h)
  std::string model_uncertainty = "auto";  // on, off; auto: on when the population has posterior draws
  std::optional<double> force_free_share;  // transfer designs only (app/plan/plan_transfer.h)
  bool measure_given = false;              // --measure on the command line
};

}  // namespace hapticlab::app
