#pragma once
// The participant-level comparison of each setting with the control: one
// number per participant and setting (the median of the measure over the
// participant's repetitions and both hands), the differences from the
// control tested with the exact sign-flip permutation test
// (stats/sign_flip.h). Unlike the thesis' pairwise Friedman, where every
// repetition and hand is a replicate, a participant counts once however
// many trials they did: the evidence grows with participants, not trials.
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "analysis/study/study_analysis.h"

namespace hapticlab::analysis {

struct ParticipantPairwiseCell {
  std::string task;
  std::string setting;  // compared with the control
  Measure measure = Measure::kForceMedian;
  std::size_t participants = 0;      // who did both (with data)
  std::optional<double> p;           // two-sided; empty when no participant did both
  double mean_difference = 0.0;      // setting minus control, in the measure's unit
  bool significant = false;          // p < the study's Šidák level
  std::string note;
};

// Every task × setting × measure; `analysis` after run_statistics (its
// Šidák level is used).
std::vector<ParticipantPairwiseCell> participant_pairwise(const StudyAnalysis& analysis);

}  // namespace hapticlab::analysis
