#pragma once
// Box-plot statistics as the thesis drew them (3.4.1.5): the box spans the
// 25th to the 75th percentile with the median inside; whiskers reach the most
// extreme data points within `whisker_iqr` × IQR of the box (3 in the
// thesis, not the usual 1.5); points beyond are outliers, drawn as '+'.
#include <cstddef>
#include <span>
#include <vector>

#include "analysis/stats/percentile.h"

namespace hapticlab::analysis {

struct BoxStats {
  std::size_t n = 0;
  double q1 = 0.0;
  double median = 0.0;
  double q3 = 0.0;
  double whisker_low = 0.0;   // smallest value >= q1 − whisker_iqr·IQR
  double whisker_high = 0.0;  // largest value <= q3 + whisker_iqr·IQR
  std::vector<double> outliers;  // ascending
};

// values: non-empty, finite; whisker_iqr >= 0. Throws DataError otherwise.
BoxStats box_stats(std::span<const double> values, double whisker_iqr = 3.0,
                   PercentileMethod method = PercentileMethod::kMatlab);

}  // namespace hapticlab::analysis
