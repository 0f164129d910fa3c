#pragma once
// The Hodges-Lehmann shift between two independent groups, the effect that
// goes with the rank-sum test: the median of all pairwise differences
// y_j - x_i, with the confidence interval from inverting the exact
// Wilcoxon-Mann-Whitney test (Hollander & Wolfe, Nonparametric Statistical
// Methods, ch. 4): the k-th smallest and k-th largest pairwise difference,
// k the largest integer with P(U <= k - 1) <= (1 - level) / 2 under the
// exact null distribution of U without ties. With ties in the data the
// interval is approximate (its coverage can exceed the stated level).
#include <cstddef>
#include <string>
#include <vector>

namespace hapticlab::analysis::transfer {

struct ShiftEstimate {
  double shift = 0.0;            // y minus x, in the values' unit
  bool has_interval = false;     // false when the groups are too small for `level`
  double low = 0.0, high = 0.0;
  double achieved_level = 0.0;   // 1 - 2 P(U <= k - 1), >= level
  std::string no_interval_reason;
};

// x, y: finite values, each at least 1. level in (0, 1). Throws DataError
// naming the group and value otherwise.
ShiftEstimate hodges_lehmann_shift(const std::vector<double>& x, const std::vector<double>& y,
                                   double level = 0.95);

// P(U <= u) for the Mann-Whitney U of groups of m and n without ties
// (exact, by counting; m * n up to 10^6).
double mann_whitney_cdf(std::size_t u, std::size_t m, std::size_t n);

}  // namespace hapticlab::analysis::transfer
