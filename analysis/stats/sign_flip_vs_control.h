#pragma once
// The participant-level comparison of each treatment with a control
// (docs/analysis.md, "Which comparison"): each block's values under a
// treatment (its repetitions, and both hands where a measure has one per
// hand) become one number, their median; the block's difference from its
// control median is one piece of evidence; the differences are tested with
// the exact sign-flip permutation test (sign_flip.h). A block counts once,
// however many trials it did, so repetitions cannot pass for participants.
// Blocks are participants in `analyze`; `stats pairwise --method
// participant` takes them from the CSV's --block column.
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "analysis/stats/block_table.h"
#include "analysis/stats/percentile.h"

namespace hapticlab::analysis {

struct SignFlipComparison {
  std::string treatment;           // compared with the control
  std::size_t blocks = 0;          // blocks with values under both
  std::optional<double> p;         // two-sided; empty when no block has both
  double mean_difference = 0.0;    // mean over blocks of (treatment median - control median)
  bool significant = false;        // p < level
};

// Every treatment of `table` but the control, in table order. `level`: the
// significance level each comparison is judged at (the Šidák level of the
// family). Throws DataError when `control` is not a treatment of the table.
std::vector<SignFlipComparison> sign_flip_vs_control(const BlockTable& table, const std::string& control,
                                                     double level, PercentileMethod median_method);

}  // namespace hapticlab::analysis
