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


// Prints the power table, writes OUT/transfer_power.csv; returns the exit
// status. Throws std::runtime_error / std::invalid_argument with the reason.
// --participants are participants per group (default: the protocol's
// participants over its groups); --force-free-share defaults to 0.5.
int run_transfer_power(const protocols::Protocol& protocol, const PlanPowerOptions& o);

// plan power's path for a protocol with groups: its exit status, after
// refusing by name the options that do not apply to a transfer design;
// nullopt for a protocol without groups (after refusing the options that
// apply only to one).
std::optional<int> run_if_transfer_design(const protocols::Protocol& protocol, const PlanPowerOptions& o);

// plan power's options for transfer designs (--force-free-share).
void add_transfer_options(CLI::App* cmd, PlanPowerOptions& o);

}  // namespace hapticlab::app
