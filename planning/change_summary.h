#pragma once
// The predicted change of each setting against the control over many
// simulated studies (planning/study_change.h gives one study's): per
// number of participants, task, setting and measure, the median study's
// change and the range that 95 % of studies of that size would see.
//
// The model's prediction, not a measurement: docs/simulation.md says where
// the simulated surgeons match published data and where not.
#include <string>
#include <vector>

#include "planning/power.h"

namespace hapticlab::planning {

struct ChangeRow {
  int participants = 0;  // simulated study size
  std::string task;
  std::string setting;
  std::string measure;
  int studies = 0;  // studies with the change (some participant had both settings)
  // The change is ratio - 1 (0.25: 25 % more than under the control):
  // its median over the studies, and their 2.5th and 97.5th percentiles.
  double median = 0.0;
  double low = 0.0, high = 0.0;
};

// Rows sorted by participants, task, setting (protocol order), measure.
std::vector<ChangeRow> summarize_changes(const std::vector<StudyOutcome>& outcomes,
                                         const std::vector<std::string>& setting_order);

// The trials of a task under a setting that timed out, over every study of
// a size: they are left out of the change and the power, so a setting under
// which the simulated surgeons often cannot finish shows it here.
struct TimeoutRow {
  int participants = 0;
  std::string task;
  std::string setting;
  int trials = 0;
  int timed_out = 0;
  double rate = 0.0;
  double wilson_low = 0.0, wilson_high = 0.0;  // 95 % Wilson score interval
};

// Rows sorted by participants, task, setting (protocol order).
std::vector<TimeoutRow> summarize_timeouts(const std::vector<StudyOutcome>& outcomes,
                                           const std::vector<std::string>& setting_order);

}  // namespace hapticlab::planning
