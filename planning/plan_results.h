#pragma once
// What a finished `plan power` plan writes: power.csv (every power row),
// each setting's predicted change beside the power to detect it
// (predicted_change.csv, comparison.md) and the power figures. A plan run
// on one machine and the same plan merged from shards (plan_merge.h) write
// the same files byte for byte; the rows come back for the command to print.
#include <filesystem>
#include <string>
#include <vector>

#include "planning/comparison_report.h"
#include "planning/plan_design.h"
#include "planning/plan_inputs.h"
#include "planning/power.h"
#include "protocols/protocol.h"

namespace hapticlab::planning {

struct PlanResults {
  std::vector<PowerRow> rows;                      // summarize_power, every measure
  std::vector<FalsePositiveRow> false_positives;   // of the design's null settings
  std::vector<StaircaseSummaryRow> staircases;     // a staircase protocol's
  std::vector<ReportVariant> variants;             // one: "model fixed" or "with model uncertainty"
  std::string comparison;                          // comparison.md's Markdown after its title
  // Per participant count whose participant-level power is 0 by
  // construction, why (participant_reach.h); also at comparison.md's end.
  std::vector<std::string> notes;
  std::filesystem::path folder;  // where they are written
  std::filesystem::path power_csv, change_csv, comparison_md;
  std::vector<std::string> figures;  // file names in the folder (none without plots)
};

// Writes DIR/power.csv, DIR/predicted_change.csv, DIR/comparison.md and,
// with `plots`, one figure of `measure` per task (gnuplot; throws when it
// is missing or fails). `outcomes` are every study of the plan `inputs`
// describes. Throws std::runtime_error when a file cannot be written.
PlanResults write_plan_results(const protocols::Protocol& protocol, const PlanInputs& inputs,
                               const PlanDesign& design, const std::vector<StudyOutcome>& outcomes,
                               const std::filesystem::path& out, const std::string& measure, bool plots);

// power.csv's text of `rows`, as write_plan_results writes it.
std::string power_csv_text(const std::vector<PowerRow>& rows);

}  // namespace hapticlab::planning
