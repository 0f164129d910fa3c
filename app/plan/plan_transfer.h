#pragma once
// `plan power` on a protocol with groups (a transfer design, issue 38 §4):
// power per group size for the post-test and the retention comparisons,
// each group against the protocol's first group, from simulated transfer
// studies (planning/transfer_power.h) analysed by the exact rank
// permutation test (analysis/transfer/group_permutation.h).
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <optional>

#include <CLI/CLI.hpp>

#include "app/plan/plan_power_options.h"
#include "protocols/protocol.h"

namespace hapticlab::app {

struct TransferPowerCli {
  std::string protocol_path;
  std::vector<int> per_group;  // --participants: participants per group; empty: the protocol's
  int studies = 200;
  std::uint64_t seed = 1;
  std::size_t jobs = 0;        // 0: one per core
  std::string out;
  double rate_Hz = 1000.0;
  double max_trial_s = 300.0;
  std::string population;      // --population
  double force_free_share = 0.5;
  bool json = false;
};

// Prints the power table, writes OUT/transfer_power.csv; returns the exit
// status. Throws std::runtime_error / std::invalid_argument with the reason.
int run_transfer_power(const protocols::Protocol& protocol, const TransferPowerCli& cli);

// plan power's path for a protocol with groups: its exit status, after
// refusing by name the options that do not apply to a transfer design;
// nullopt for a protocol without groups (after refusing the options that
// apply only to one).
std::optional<int> run_if_transfer_design(const protocols::Protocol& protocol, const PlanPowerOptions& o);

// plan power's options for transfer designs (--force-free-share).
void add_transfer_options(CLI::App* cmd, PlanPowerOptions& o);

}  // namespace hapticlab::app
