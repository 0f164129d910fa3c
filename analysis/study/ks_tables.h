#pragma once
// The study's KS table (Appendix I): control against each other setting, per
// task, hand and quantity, by the moving block bootstrap, the comparisons
// run on several threads with the same numbers as one.
#include "analysis/study/study_analysis.h"

namespace hapticlab::analysis {

// Fills analysis.ks from analysis.trials' force and speed series, in the
// order task, hand, quantity ("force", "speed"), setting. Each comparison
// has its own seed (options.seed and its position in that order), so the
// table does not depend on `threads` (0: one per core, capped by the number
// of comparisons).
void add_ks_rows(StudyAnalysis& analysis, std::size_t threads);

}  // namespace hapticlab::analysis
