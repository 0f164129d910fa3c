#pragma once
// What one simulated study says a setting does to each measure, against the
// control: per participant, the ratio of their medians (over repetitions
// and, for a per-hand measure, both hands) under the setting and under the
// control; the study's change is the median of those ratios. It is the
// size of the effect that plan power's significance counts cannot show
// (planning/change_summary.h gathers it over many studies).
//
// A simulated study's change is the model's prediction, not a measurement:
// docs/simulation.md says where the simulated surgeons match published data
// and where not.
#include <string>
#include <vector>

#include "analysis/study/study_analysis.h"

namespace hapticlab::planning {

struct ChangeOutcome {
  std::string task;
  std::string setting;  // compared with the study's control
  std::string measure;  // metrics.csv column, e.g. force_p95_N
  int participants = 0;  // who have data under both, with a control median above 0
  double ratio = 0.0;    // median over them of (median under the setting) / (median under the control)
};

// Every task × setting (not the control) × measure of `analysis` that some
// participant has data for under both settings, in task, setting (study
// order) and measure order. Empty when the analysis has no control.
std::vector<ChangeOutcome> changes_of(const analysis::StudyAnalysis& analysis);

}  // namespace hapticlab::planning
