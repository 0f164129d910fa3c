#pragma once
// Runs a plan's studies: simulates the studies still to do on a pool of
// threads, each drawing its population (the fit's point estimate, or with
// the model's uncertainty one posterior draw per group of studies,
// power.h), and stores each in the plan's PowerStore as it finishes
// (committed: an interrupted or failed run keeps what it stored, and the
// same command resumes). What `plan power` does between reading its options
// and writing its tables.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <utility>
#include <vector>

#include "core/sim/population.h"
#include "planning/power_store.h"
#include "planning/simulated_study.h"
#include "protocols/protocol.h"

namespace hapticlab::planning {

struct PlanRunOptions {
  std::uint64_t seed = 1;          // the plan's seed (power.h run_power_study)
  SimulatedStudyOptions sim;       // rate, time limit, the point population
  // Non-empty: the model's uncertainty; study k of a size draws
  // draws[draw_of_group(draw_group(k), draws.size())].
  std::vector<PopulationParams> draws;
  std::size_t jobs = 1;            // threads, >= 1
  // Polled between studies: true stops taking new ones (running ones end).
  std::function<bool()> interrupted;
  // Called on the caller's thread at least every 200 ms and after each
  // batch stored: studies stored by this run so far, seconds since start.
  std::function<void(std::size_t stored, double elapsed_s)> on_progress;
};

struct PlanRunResult {
  std::size_t stored = 0;     // studies simulated and stored by this run
  std::uint64_t updates = 0;  // their loop updates
  double elapsed_s = 0.0;
};

// A study that could not be stored (a full disk): what was stored before
// stays; `stored` says how many this run stored.
class PlanStoreFailure : public std::runtime_error {
 public:
  PlanStoreFailure(const std::string& what, std::size_t stored) : std::runtime_error(what), stored(stored) {}
  std::size_t stored;
};

// What a run of a plan (or of its shard) has to do: the shard's studies
// (PlanInputs::studies_of_shard) not yet in `store`, in the plan's order.
struct PlanWork {
  std::vector<std::pair<int, int>> todo;
  std::size_t total = 0;    // the shard's studies
  std::size_t already = 0;  // of them stored before (a resumed run)
};
PlanWork plan_work(const PlanInputs& inputs, PowerStore& store);

// Threads for `todo` studies: `requested`, or with 0 two per core (each
// study's haptic loop runs on its own thread while the study's thread
// sleeps between draining its samples, so one study per core leaves the
// cores partly idle: 4 thesis-sized studies on 2 cores took 12.5 s with 2
// jobs, 10.5 s with 4); never more than the studies, at least 1.
std::size_t plan_jobs(std::size_t requested, std::size_t todo);

// Simulates `todo` ((participants, index) pairs) into `store`. Rethrows a
// study's own error after the running studies end; throws PlanStoreFailure
// when storing fails.
PlanRunResult run_plan_studies(const protocols::Protocol& protocol, const std::vector<std::pair<int, int>>& todo,
                               PowerStore& store, const PlanRunOptions& options);

}  // namespace hapticlab::planning
