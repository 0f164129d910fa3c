#pragma once
// Learning curves of every participant of a trial table (issue 38 §2): the
// three fits of curve_fit.h on one phase's trials (training by default),
// and optionally the CUSUM chart against a proficiency criterion; written
// as CSV (docs/analysis.md "Output columns").
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "analysis/learning/curve_fit.h"
#include "analysis/learning/cusum.h"
#include "analysis/learning/trial_table.h"

namespace hapticlab::analysis::learning {

struct CusumCriterion {
  double criterion = 0.0;         // in the measure's unit
  bool higher_is_better = false;  // false: a trial fails above the criterion
  CusumSpec spec;
};

struct ParticipantLearning {
  std::string participant;
  std::string group;
  std::vector<double> trial, value;  // the phase's trials
  LearningCurve curve;
  std::optional<CusumChart> cusum;
};

struct LearningAnalysis {
  std::string measure;
  Phase phase = Phase::kTraining;
  std::vector<ParticipantLearning> participants;  // those with trials in `phase`
};

// Throws DataError when no participant has trials in `phase`, or for a bad
// CUSUM specification (cusum.h).
LearningAnalysis analyze_learning(const TrialTable& table, Phase phase,
                                  const std::optional<CusumCriterion>& cusum);

// One row per participant and family: participant, group, family, status
// (ok or the refusal's name), chosen (1 for the AICc choice), n, plateau,
// plateau_se, excess, excess_se, rate, rate_se, rate_kind (c or tau_trials),
// trials_to_90, beyond_data, residual_sd, aicc, akaike_weight, reason.
void write_curves_csv(const LearningAnalysis& analysis, std::ostream& out);
// One row per participant and trial: participant, group, trial, value,
// failure, score, lc_score, h0, h1, s.
void write_cusum_csv(const LearningAnalysis& analysis, std::ostream& out);

}  // namespace hapticlab::analysis::learning
