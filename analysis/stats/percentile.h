#pragma once
// Percentiles of a sample under several published definitions.
//
// The default is MATLAB's `prctile` (Statistics Toolbox), because the thesis'
// 50th and 95th percentile forces were computed in MATLAB: with the n values
// sorted, x(i) sits at percentile 100·(i − 0.5)/n; between two such points the
// percentile is interpolated linearly, and below the first / above the last
// it is clamped to the minimum / maximum. (This is Hyndman & Fan type 5.)
//
// Other definitions, for comparing with other tools:
//   kR7          Hyndman & Fan type 7: h = (n − 1)·p/100 + 1, linear
//                interpolation (R's and numpy's default, Excel PERCENTILE.INC).
//   kR6          type 6: h = (n + 1)·p/100, clamped to [1, n], linear
//                (Minitab, SPSS, Excel PERCENTILE.EXC inside its range).
//   kNearestRank the smallest value with at least p % of the sample at or
//                below it: x(ceil(n·p/100)), x(1) for p = 0.
#include <cstddef>
#include <span>
#include <string_view>
#include <vector>

namespace hapticlab::analysis {

enum class PercentileMethod { kMatlab, kR7, kR6, kNearestRank };

// "matlab" (or "r5"), "r7" (or "numpy", "excel"), "r6", "nearest" (or
// "nearest-rank"). Case-sensitive. Throws DataError naming the value and the
// accepted names.
PercentileMethod parse_percentile_method(std::string_view name);
// The canonical name ("matlab", "r7", "r6", "nearest").
std::string_view percentile_method_name(PercentileMethod method);

// p_percent in [0, 100]; values non-empty and finite, any order (copied and
// sorted internally). Throws DataError otherwise.
double percentile(std::span<const double> values, double p_percent,
                  PercentileMethod method = PercentileMethod::kMatlab);

// Same, for values already sorted ascending (not checked); no allocation.
double percentile_sorted(std::span<const double> sorted, double p_percent,
                         PercentileMethod method = PercentileMethod::kMatlab);

// Where percentile p falls among n sorted values (0-based): the percentile is
// x[lower] + fraction·(x[upper] − x[lower]), or x[lower] when upper == lower.
struct PercentilePosition {
  std::size_t lower = 0;
  std::size_t upper = 0;
  double fraction = 0.0;
};
// n >= 1, p_percent in [0, 100]; throws DataError otherwise.
PercentilePosition percentile_position(std::size_t n, double p_percent,
                                       PercentileMethod method = PercentileMethod::kMatlab);

// Several percentiles of unsorted values by selection (order_statistics.h)
// rather than a full sort: the same order statistics, so the very results of
// percentile_sorted on the sorted values. May reorder `values`; values
// non-empty and finite (not checked).
std::vector<double> percentiles_select(std::vector<double>& values, std::span<const double> p_percents,
                                       PercentileMethod method = PercentileMethod::kMatlab);

}  // namespace hapticlab::analysis
