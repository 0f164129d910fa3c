#pragma once
// Rank-based permutation test of k >= 2 independent groups (issue 38 §3):
// the Kruskal-Wallis statistic H on mid-ranks, its p-value from the
// permutation distribution of the group labels rather than the chi-square
// approximation. With two groups H is a monotone function of |W - E W|
// (W the Wilcoxon rank sum), so the test is the two-sided exact
// Wilcoxon-Mann-Whitney test, computed exactly at any size by counting the
// splits per rank sum (ties included). With three or more groups: exact
// enumeration of every distinct assignment of labels when there are at most
// `max_exact` of them; else a seeded Monte Carlo of `monte_carlo` random
// assignments, with p = (1 + hits) / (1 + draws) and its Wilson interval.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "analysis/stats/wilson.h"

namespace hapticlab::analysis::transfer {

struct PermutationOptions {
  double max_exact = 1e6;            // largest number of assignments enumerated
  std::size_t monte_carlo = 100000;  // draws when not exact, >= 1000
  std::uint64_t seed = 1;
};

struct PermutationResult {
  double h = 0.0;                 // Kruskal-Wallis H (tie-corrected)
  double p_value = 1.0;           // P(H* >= H) under random assignment
  bool exact = false;
  double assignments = 0.0;       // distinct assignments (multinomial), exact or not
  std::size_t evaluated = 0;      // assignments enumerated, Monte Carlo draws, 0 when counted (2 groups)
  ProportionInterval p_interval;  // [p, p] when exact; Wilson 95 % when Monte Carlo
};

// groups[g] holds the finite values of group g. Throws DataError naming the
// group index for fewer than 2 groups, an empty group, a non-finite value,
// or fewer than 1000 Monte Carlo draws.
PermutationResult group_permutation_test(const std::vector<std::vector<double>>& groups,
                                         const PermutationOptions& options = {});

}  // namespace hapticlab::analysis::transfer
