#pragma once
// Prints a finished plan's results (planning/plan_results.h) for plan power
// and plan merge: the power tables, false positives, staircases and the
// predicted change, or with --json one JSON object of them all.
#include <cstddef>
#include <string>

#include "planning/plan_design.h"
#include "planning/plan_inputs.h"
#include "planning/plan_results.h"
#include "protocols/protocol.h"

namespace hapticlab::app {

// This run's work, for the summary line and --json.
struct PlanRunSummary {
  std::string did;  // "12 studies simulated in 3.1 s (...)", or the merge's
  double seconds_this_run = 0.0;
  std::size_t studies_this_run = 0;
  std::string population;  // whom the studies simulated, in words
};

void print_plan_results(const protocols::Protocol& protocol, const planning::PlanInputs& inputs,
                        const planning::PlanDesign& design, const planning::PlanResults& results,
                        const std::string& measure, bool json, const PlanRunSummary& run);

}  // namespace hapticlab::app
