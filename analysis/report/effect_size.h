#pragma once
// Effect sizes to print beside the p values of the rank tests.
#include <cstddef>
#include <vector>

namespace hapticlab::analysis {

// Kendall's coefficient of concordance from a Friedman statistic:
// W = chi2 / (b (k - 1)) for b blocks and k treatments. With chi2 the
// tie-corrected statistic (as R's friedman.test gives it) this is the
// tie-corrected W. Range [0, 1]: 0 no agreement between blocks, 1 every block
// ranks the treatments alike. Throws DataError when b < 1 or k < 2.
double kendalls_w(double friedman_chi2, std::size_t blocks, std::size_t treatments);

// Matched-pairs rank-biserial correlation of paired differences d_i = x_i - y_i
// (Kerby 2014): r = (T+ - T-) / (T+ + T-), with T+ and T- the sums of the
// ranks of |d_i| (average ranks for ties) over the positive and the negative
// differences; zero differences are dropped, as in Wilcoxon's signed-rank test.
// Range [-1, 1]: +1 when every x is above its y. 0 when every difference is 0.
// Non-finite differences throw DataError.
double matched_pairs_rank_biserial(const std::vector<double>& differences);

}  // namespace hapticlab::analysis
