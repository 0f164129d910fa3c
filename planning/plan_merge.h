#pragma once
// `plan merge`: the folders of one plan's shards (plan power --shard I/N,
// e.g. a Slurm job array), checked to be the shards of one plan (protocol,
// settings, options, seed, version), each once and all of them, complete
// and undamaged, merged into one plan folder that holds and writes what a
// one-machine run of the plan does (plan_results.h), byte for byte. Nothing
// in the shards' folders is written.
#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "planning/plan_design.h"
#include "planning/plan_inputs.h"
#include "planning/plan_results.h"
#include "protocols/protocol.h"

namespace hapticlab::planning {

struct PlanMergeRequest {
  std::vector<std::string> shards;  // folders of `plan power --shard I/N`, as named (messages quote them)
  std::string out;                  // the merged plan's folder, not one of the shards'
  std::string protocol;             // default (empty): the file the shards name
  std::string measure = "force_p95_N";  // of the figures
  bool plots = true;
};

struct PlanMerge {
  protocols::Protocol protocol;
  PlanInputs whole;   // the plan the shards are parts of
  PlanDesign design;
  std::size_t studies = 0;  // of the plan
  std::size_t added = 0;    // to the merged store by this merge
  std::size_t already = 0;  // in the merged store before (an earlier merge)
  std::filesystem::path store;  // OUT/plan_power.db
  PlanResults results;
};

// Checks and merges; `note` gets each note of the design check
// (plan_design.h) as it is made. Throws std::runtime_error naming the
// folder and what is wrong: --out among the shards, a folder named twice,
// one without plan_power.db or holding a whole plan, a shard of another
// plan (naming what differs), a shard twice or missing, a protocol that is
// not where the shards read it or not the same, a damaged or incomplete
// store (PowerStore's refusals), a plan folder another run holds, or a
// store that cannot be written (the studies merged so far are kept).
PlanMerge merge_plan_shards(const PlanMergeRequest& request, const std::function<void(const std::string&)>& note);

}  // namespace hapticlab::planning
