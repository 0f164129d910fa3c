#include "analysis/stats/ranks.h"

#include <algorithm>
#include <numeric>

namespace hapticlab::analysis {

Ranking average_ranks(std::span<const double> values) {
  const std::size_t n = values.size();
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t{0});
  // stable: equal values keep their input order, which does not change the ranks
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return values[a] < values[b]; });
  Ranking result;
  result.ranks.assign(n, 0.0);
  std::size_t start = 0;
  while (start < n) {
    std::size_t end = start + 1;
    while (end < n && values[order[end]] == values[order[start]]) ++end;
    // positions start..end-1 hold ranks start+1..end; their mean is (start+1+end)/2
    const double mid_rank = (static_cast<double>(start + 1) + static_cast<double>(end)) / 2.0;
    for (std::size_t i = start; i < end; ++i) result.ranks[order[i]] = mid_rank;
    const double t = static_cast<double>(end - start);
    result.tie_term += t * t * t - t;
    start = end;
  }
  return result;
}

}  // namespace hapticlab::analysis
