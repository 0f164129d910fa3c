#pragma once
// Effect sizes to print beside the p values of the rank tests.
#include <cstddef>
#include <vector>

#include "analysis/stats/block_table.h"

namespace hapticlab::analysis {

// Kendall's coefficient of concordance from a Friedman statistic:
// W = chi2 / (b (k - 1)) for b blocks and k treatments. With chi2 the
// tie-corrected statistic (as R's friedman.test gives it) this is the
// tie-corrected W. Range [0, 1]: 0 no agreement between blocks, 1 every block
// ranks the treatments alike. Throws DataError when b < 1, k < 2 or r < 1.
//
// With r replicates per cell ranked together within a block (MATLAB's
// friedman(X, reps), the thesis' Table 3.4), W is the statistic over its
// largest possible value, reached when every block puts all r replicates of
// one treatment below all of the next: Q_max = b r^2 (k^2 - 1) / (r k + 1)
// (worked out in docs/analysis.md), which is b (k - 1) for r = 1.
double kendalls_w(double friedman_chi2, std::size_t blocks, std::size_t treatments, std::size_t replicates = 1);

// Matched-pairs rank-biserial correlation of paired differences d_i = x_i - y_i
// (Kerby 2014): r = (T+ - T-) / (T+ + T-), with T+ and T- the sums of the
// ranks of |d_i| (average ranks for ties) over the positive and the negative
// differences; zero differences are dropped, as in Wilcoxon's signed-rank test.
// Range [-1, 1]: +1 when every x is above its y. 0 when every difference is 0.
// Non-finite differences throw DataError.
double matched_pairs_rank_biserial(const std::vector<double>& differences);

// The rank-biserial r of `treatment` against `control` over the blocks of a
// (balanced) table: each block contributes the median of its `treatment`
// values minus the median of its `control` values (the ordinary median,
// the mean of the middle two for an even count). Blocks missing either cell
// are skipped. Throws DataError when no block has both.
double paired_rank_biserial(const BlockTable& table, std::size_t control, std::size_t treatment);

}  // namespace hapticlab::analysis
