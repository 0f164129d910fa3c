#pragma once
// Friedman's two-way analysis of variance by ranks, with or without
// replicates (Friedman 1937; thesis 3.3.7.1, equation 3.3).
//
// Each block's r·k observations (k treatments, r replicates per cell, r >= 1)
// are ranked together, ties sharing mid-ranks. With R_j the rank sum of
// treatment j over all b blocks and N = r·k,
//
//   Q = Σ_j (R_j − b·r·(N+1)/2)² / (b·r·σ²),
//   σ² = N(N+1)/12 − Σ_blocks Σ_ties (t³ − t) / (12·b·(N − 1)),
//
// referred to chi-square with k − 1 degrees of freedom. For r = 1 this is the
// tie-corrected statistic of R's friedman.test and scipy's
// friedmanchisquare; for r > 1 it is MATLAB's friedman(x, reps) ("Columns"
// Chi-sq), where replicates are ranked together with their block as Zar
// (1996) describes and the thesis did. When every block is entirely tied the
// statistic is 0 and p = 1.
#include "analysis/stats/block_table.h"
#include "analysis/stats/test_result.h"

namespace hapticlab::analysis {

// table: >= 1 block, >= 2 treatments, every cell holding the same number of
// observations (>= 1), all finite. A missing cell or unequal replicate counts
// throw DataError naming the block and treatment (missing cells: use
// skillings_mack_test). result.observations = b·r·k.
TestResult friedman_test(const BlockTable& table);

}  // namespace hapticlab::analysis
