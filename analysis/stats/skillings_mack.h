#pragma once
// The Skillings–Mack test for block designs with missing cells (Skillings &
// Mack 1981, Technometrics 23(2) 171–177), the thesis' situation when each
// participant did only some of the settings (Table 3.3).
//
// In block i with k_i >= 2 observed treatments, rank the observations (mid-
// ranks for ties). The adjusted treatment sums are
//   A_j = Σ_i sqrt(12/(k_i + 1)) · (r_ij − (k_i + 1)/2)   (missing cells add 0),
// with null covariance Σ_jj = Σ_i over blocks holding j of (k_i − 1) and
// Σ_jl = −(number of blocks holding both j and l). The statistic
//   SM = Aᵀ Σ⁻ A   (Σ⁻ a generalized inverse; Σ has rank t − 1)
// is referred to chi-square with t − 1 degrees of freedom. Blocks with fewer
// than two observations carry no information and are left out. With complete
// blocks and no ties SM equals Friedman's statistic.
#include "analysis/stats/block_table.h"
#include "analysis/stats/test_result.h"

namespace hapticlab::analysis {

// table: >= 2 treatments; cells empty or one finite value. Throws DataError
// for a cell with replicates, or when the treatments are not connected
// through shared blocks (Σ of rank < t − 1: no valid chi-square reference).
// result.blocks counts the blocks used (those with >= 2 observations).
TestResult skillings_mack_test(const BlockTable& table);

}  // namespace hapticlab::analysis
