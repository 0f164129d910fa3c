#pragma once
// Durbin's test for a balanced incomplete block design (Durbin 1951), in
// Conover's formulation with ties (Practical Nonparametric Statistics, 3rd
// ed., 1999, section 5.9):
//
//   t treatments, b blocks of k < t observed treatments each (one
//   observation per cell), every treatment in r blocks. Ranks within blocks
//   (mid-ranks for ties), R_j the rank sum of treatment j,
//   A = Σ rank², C = b·k·(k+1)²/4,
//   T1 = (t − 1)·Σ_j (R_j − r(k+1)/2)² / (A − C)        ~ chi-square(t − 1)
//   T2 = (T1/(t − 1)) / ((b(k − 1) − T1)/(b·k − b − t + 1)) ~ F(t − 1, b·k − b − t + 1)
//
// Without ties T1 = 12(t−1)/(r·t·(k−1)(k+1)) · Σ_j (R_j − r(k+1)/2)².
// A complete design (k = t) is accepted too; T1 is then Friedman's statistic.
#include "analysis/stats/block_table.h"
#include "analysis/stats/test_result.h"

namespace hapticlab::analysis {

struct DurbinResult {
  TestResult chi_square;  // T1, df = t − 1
  double f = 0.0;         // T2, the F form; infinite when T1 reaches b(k − 1)
  double f_df1 = 0.0;
  double f_df2 = 0.0;
  double f_p = 1.0;      // NaN when f_df2 <= 0 (too few blocks for the F form)
};

// table: >= 2 treatments; every cell empty or one finite value; every block
// the same size k >= 2; every treatment in the same number of blocks; every
// pair of treatments together in the same number of blocks (the BIBD
// balance). Throws DataError naming the offending block or treatment.
DurbinResult durbin_test(const BlockTable& table);

}  // namespace hapticlab::analysis
