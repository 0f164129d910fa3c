#include "analysis/report/box_stats.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {

BoxStats box_stats(std::span<const double> values, double whisker_iqr, PercentileMethod method) {
  if (values.empty()) throw DataError("box plot: no values");
  if (!(std::isfinite(whisker_iqr) && whisker_iqr >= 0.0)) {
    throw DataError("box plot: whisker_iqr is " + std::to_string(whisker_iqr) + ", but must be >= 0");
  }
  std::vector<double> sorted(values.begin(), values.end());
  for (double v : sorted)
    if (!std::isfinite(v)) throw DataError("box plot: a value is not finite");
  std::sort(sorted.begin(), sorted.end());
  BoxStats b;
  b.n = sorted.size();
  b.q1 = percentile_sorted(sorted, 25.0, method);
  b.median = percentile_sorted(sorted, 50.0, method);
  b.q3 = percentile_sorted(sorted, 75.0, method);
  const double reach = whisker_iqr * (b.q3 - b.q1);
  const double low_fence = b.q1 - reach;
  const double high_fence = b.q3 + reach;
  b.whisker_low = b.q1;
  b.whisker_high = b.q3;
  for (double v : sorted) {
    if (v < low_fence || v > high_fence) {
      b.outliers.push_back(v);
    } else {
      b.whisker_low = std::min(b.whisker_low, v);
      b.whisker_high = std::max(b.whisker_high, v);
    }
  }
  return b;
}

}  // namespace hapticlab::analysis
