#pragma once
// One participant's adaptive staircase (protocols/staircase.h) as the study
// database holds it: the baseline from their complete trials under the
// baseline setting, and the rule replayed over their complete staircase
// trials. `session run` plans the next trial from it; `analyze` reports the
// thresholds. Nothing about the staircase is stored but its trials, so a
// crash loses no state.
//
// Staircase trials are the participant's trials in block 0 (a designed
// schedule's blocks start at 1), each at a setting made from the stored
// base settings at one strength (settings_at_strength).
#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "analysis/study/study_analysis.h"
#include "db/study_db.h"
#include "protocols/staircase.h"

namespace hapticlab::analysis {

// A participant without a baseline: nothing to measure a change from. Its
// own type, so a database failure is never taken for it.
class StaircaseBaselineError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct StaircaseProgress {
  protocols::StaircaseSpec spec;
  std::string base_name;            // the strengths' settings are named after it
  std::int64_t base_setting_id = 0;  // the stored base settings' row
  double baseline = 0.0;            // median of the measure over the baseline trials (and hands)
  std::size_t baseline_trials = 0;
  std::size_t started = 0;          // staircase trials of any status
  protocols::StaircaseState state;  // over the complete ones, in schedule order
};

// A trial's value of the measure a staircase follows ("force_p95_N", ...):
// the median over the hands with data for a per-hand measure. NaN when the
// trial has none. From its record (a simulated study), or read from the database.
double staircase_value(const TrialRecord& record, const std::string& measure);
double staircase_measure(db::StudyDb& db, const db::TrialRow& trial, const std::string& measure);

// The baseline from the baseline trials' values: their median, or empty
// when there is none or it is not above 0 (a change is a fraction of it).
std::optional<double> staircase_baseline(const std::vector<double>& values);

// Empty when the study's protocol has no staircase, or the participant has
// no trial in its task. Throws StaircaseBaselineError naming staircase.baseline
// when the participant has no complete baseline trial with a value above 0
// (nothing to measure a change from).
std::optional<StaircaseProgress> staircase_progress(db::StudyDb& db, const db::StudyRow& study,
                                                    std::int64_t participant_id);

// One line for the operator: "staircase of translation.friction.dynamic_level_N
// (force_p95_N, a change of 20 % from 0.61): threshold 0.42 after 16 trials
// (8 reversals)", or where it stands while it runs.
std::string staircase_summary(const StaircaseProgress& progress);

}  // namespace hapticlab::analysis
