#pragma once
// Roscoe's transfer effectiveness ratio (Roscoe 1971, Human Factors
// 13:561): TER = (Yc - Yx) / X, the real-task practice saved per unit of
// simulator practice. In HapticLab's terms (docs/analysis.md):
//   Yc  mean trials to criterion in the post-test of the control group,
//       which trained on no simulator (no training-phase trials),
//   Yx  the same for a group trained on a simulator setting,
//   X   mean training-phase trials of that group.
// A participant who never meets the criterion in the post-test has no
// trials to criterion: the ratio is refused rather than guessed.
#include <cstddef>
#include <vector>

namespace hapticlab::analysis::transfer {

struct TransferRatio {
  double ter = 0.0;
  double control_trials_to_criterion = 0.0;       // Yc
  double experimental_trials_to_criterion = 0.0;  // Yx
  double training_trials = 0.0;                   // X
};

// Throws DataError for an empty group, a non-finite or negative value, or
// X = 0 (the group did not train on the simulator).
TransferRatio transfer_effectiveness_ratio(const std::vector<double>& control_y,
                                           const std::vector<double>& experimental_y,
                                           const std::vector<double>& experimental_x);

}  // namespace hapticlab::analysis::transfer
