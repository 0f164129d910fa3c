#pragma once
// Everything a `plan power` plan's results depend on: the protocol's text,
// every setting it resolves as loaded and re-serialised (so a settings
// file's white space does not matter but any value does, also one changed
// under the same file name), the staircase's base settings, the options
// that change a study or the table (seed, participant counts, studies,
// loop rate, time limit, alpha, percentiles) and the software that
// simulates. plan_power.db stores them; a resumed plan whose inputs differ
// is refused, naming what changed, never mixed with the stored studies.
#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "planning/simulated_study.h"
#include "protocols/protocol.h"

namespace hapticlab::planning {

struct PlanSetting {
  std::string name;
  std::string source;  // as the protocol gives it: a file path, "inline", or a dose strength
  std::string sha256;  // of settings_to_json(...).dump(): the settings as loaded
};

struct PlanInputs {
  std::string protocol_file;    // as given on the command line; not compared (a copy elsewhere is the same plan)
  std::string protocol_sha256;  // of its text
  std::vector<PlanSetting> settings;      // the protocol's, in its order (dose strengths included)
  std::vector<PlanSetting> staircase;     // its staircase's base settings, if it has one
  std::string software;                   // software_version(): the simulation is the code's
  std::uint64_t seed = 0;
  std::vector<int> participants;          // sorted, each once
  int studies = 0;
  double rate_Hz = 0.0;
  double max_trial_s = 0.0;
  double alpha = 0.0;
  std::string percentiles;
  // The simulated participants' population: "sha256 <hex>" of its file, or
  // "unfitted model <version>"; and whether each study draws its population
  // from the file's posterior (the model's uncertainty) or takes its point.
  std::string population;
  bool model_uncertainty = false;
  // --shard I/N: this run simulates the plan's studies k (in the order of
  // studies(), counting from 0) with k mod N = I; N = 1 is the whole plan.
  int shard = 0;
  int shards = 1;

  // The plan's studies, (participants, index), participant counts in
  // increasing order and each count's studies in index order.
  std::vector<std::pair<int, int>> studies_of_plan() const;
  // The studies of this shard of the plan (all of them when shards = 1).
  std::vector<std::pair<int, int>> studies_of_shard() const;
  // Which shard (0..shards-1) simulates study `index` with `participants`.
  int shard_of(int participants, int index) const;
  // The same plan whole (shard 0 of 1): what `plan merge` makes of its shards.
  PlanInputs whole() const;

  nlohmann::json to_json() const;
  // Throws std::runtime_error when `j` is not such an object.
  static PlanInputs from_json(const nlohmann::json& j);
  // "tiny.json (sha256 0123456789ab…), settings 'High Fidelity', 'No Force Feedback', --seed 1, ..."
  std::string describe() const;
};

PlanInputs plan_inputs(const protocols::Protocol& protocol, const std::string& protocol_file,
                       const std::string& protocol_text, std::uint64_t seed, std::vector<int> participants,
                       int studies, const SimulatedStudyOptions& options);

// What differs between the inputs a plan was made from and a run's, in
// words ("settings[1] 'No Force Feedback' (no_force_feedback.json), now
// 'High Fidelity'"), one per difference; empty when they are the same plan.
std::vector<std::string> plan_differences(const PlanInputs& stored, const PlanInputs& now);

// What a result table without a plan store (transfer_power.csv,
// calibration.csv) was made from, written atomically to `file` as JSON:
// the inputs' to_json() with `extra`'s keys added (options the inputs do
// not hold). Throws OutputFileError naming the file when it cannot be
// written.
void write_inputs_record(const std::filesystem::path& file, const PlanInputs& inputs, const nlohmann::json& extra);

}  // namespace hapticlab::planning
