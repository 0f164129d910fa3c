#pragma once
// Ranks with ties: tied values share the mean of the ranks they occupy
// ("average" or mid-ranks), ranks start at 1 for the smallest value.
#include <span>
#include <vector>

namespace hapticlab::analysis {

struct Ranking {
  std::vector<double> ranks;  // ranks[i] is the rank of values[i], in [1, n]
  // Σ (t³ − t) over groups of t tied values: the tie term used by every
  // rank test's variance correction (0 when there are no ties).
  double tie_term = 0.0;
};

// values: finite (not checked); any order. O(n log n).
Ranking average_ranks(std::span<const double> values);

}  // namespace hapticlab::analysis
