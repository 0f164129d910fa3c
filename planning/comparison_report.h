#pragma once
// "Which cheap device is good enough?" answered before anything is built
// (issue 35 §4): for every setting of a plan-power run (device presets, or
// the strengths of a dose series) against the control, per task and
// measure, the predicted change and the power to detect it, at each number
// of participants. A study's change is study_change.h's, gathered by
// change_summary.h; power is power.h's share of significant studies.
//
// Every table says that these are the model's predictions: the simulated
// surgeons', not measurements (docs/simulation.md).
//
// The report takes one or more variants of the same plan, each a way its
// studies were simulated ("model fixed": the population's parameters as the
// model has them, so the spread between studies is sampling only; a fitted
// population's uncertainty drawn per study is another variant). Each
// variant adds its own change and power columns beside the others'.
#include <string>
#include <vector>

#include "planning/change_summary.h"
#include "planning/power.h"

namespace hapticlab::planning {

struct ReportVariant {
  std::string label;  // what the spread between studies includes, e.g. "model fixed"
  std::vector<ChangeRow> changes;
  std::vector<PowerRow> power;
  std::vector<TimeoutRow> timeouts;  // trials left out of both, per setting
};

struct ComparisonReportOptions {
  std::string control;              // the control setting's name
  std::string method = "participant_pairwise";  // the PowerRow method of the power columns
  std::vector<int> participants;    // study sizes, one column pair each, in this order
  std::vector<std::string> settings;  // setting order (the protocol's)
};

// Markdown: a paragraph saying what the numbers are and that they are the
// model's, then one table per task: a row per measure and setting, for each
// variant and study size a "predicted change" cell (median study, and the
// 2.5-97.5 % of studies) and a "power" cell (share significant, Wilson 95 %);
// under each table, the share of each setting's trials that timed out.
std::string comparison_markdown(const std::vector<ReportVariant>& variants, const ComparisonReportOptions& options);

// CSV, one line per variant, study size, task, setting and measure (in
// the options' setting order): the predicted change (median, 2.5 %,
// 97.5 % of studies, as fractions), both methods' power with their Wilson
// intervals, and the setting's trials run and timed out in the task; empty
// where a study size has none.
std::string comparison_csv(const std::vector<ReportVariant>& variants, const ComparisonReportOptions& options);

}  // namespace hapticlab::planning
