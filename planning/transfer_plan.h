#pragma once
// A protocol's between-group training design (protocols/transfer_design.h)
// as the simulated transfer studies plan power runs (transfer_study.h):
// one design per task, since a simulated participant's practice counts per
// task. The phases become the familiarization (the protocol's
// training_trials), the pre-test, each group's training (its sittings
// times the task's trials per sitting, on the group's setting; none for a
// control group), the post-test and the retention test; the minimum gaps
// between sittings have no part in the simulation, whose participants do
// not forget (transfer_study.h).
#include <string>
#include <vector>

#include "planning/transfer_study.h"
#include "protocols/protocol.h"

namespace hapticlab::planning {

// Throws std::invalid_argument naming what cannot be simulated: a protocol
// without groups, tests on different settings (the simulation tests on
// one), or participants with different training_trials.
std::vector<TransferDesign> transfer_designs(const protocols::Protocol& protocol);

}  // namespace hapticlab::planning
