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

// Every task × setting × measure (cells: study_analysis.h); run_statistics
// stores them in StudyAnalysis::participant_pairwise. Needs the Šidák level
// of `analysis`.
std::vector<ParticipantPairwiseCell> participant_pairwise(const StudyAnalysis& analysis);

}  // namespace hapticlab::analysis
