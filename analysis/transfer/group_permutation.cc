#include "analysis/transfer/group_permutation.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "analysis/stats/data_error.h"
#include "analysis/stats/ranks.h"
#include "analysis/stats/split_mix64.h"

namespace hapticlab::analysis::transfer {
namespace {

// Sum over groups of R_g^2 / n_g: H up to constants fixed by the data, so
// permutations compare on it directly.
double rank_statistic(const std::vector<double>& ranks, const std::vector<int>& labels,
                      std::vector<double>& sums, const std::vector<double>& sizes) {
  std::fill(sums.begin(), sums.end(), 0.0);
  for (std::size_t i = 0; i < ranks.size(); ++i) sums[static_cast<std::size_t>(labels[i])] += ranks[i];
  double s = 0.0;
  for (std::size_t g = 0; g < sums.size(); ++g) s += sums[g] * sums[g] / sizes[g];
  return s;
}

// Two groups: the exact distribution of twice the rank sum of group 0 over
// all C(N, n0) splits, by counting subsets (twice a mid-rank is an integer,
// so ties are exact too). Far cheaper than enumerating the splits, and
// exact at any size.
double two_group_exact_p(const std::vector<double>& ranks, std::size_t n0) {
  std::vector<long> twice(ranks.size());
  long total = 0;
  for (std::size_t i = 0; i < ranks.size(); ++i) {
    twice[i] = std::lround(2.0 * ranks[i]);
    total += twice[i];
  }
  long observed = 0;
  for (std::size_t i = 0; i < n0; ++i) observed += twice[i];
  // count[j][s]: subsets of j of the items seen so far with sum s.
  std::vector<std::vector<double>> count(n0 + 1, std::vector<double>(static_cast<std::size_t>(total) + 1, 0.0));
  count[0][0] = 1.0;
  for (std::size_t i = 0; i < twice.size(); ++i) {
    for (std::size_t j = std::min(i + 1, n0); j >= 1; --j) {
      const auto t = static_cast<std::size_t>(twice[i]);
      for (std::size_t sum = static_cast<std::size_t>(total); sum >= t; --sum) count[j][sum] += count[j - 1][sum - t];
    }
  }
  const double center = static_cast<double>(n0) * static_cast<double>(total) / static_cast<double>(ranks.size());
  const double distance = std::abs(static_cast<double>(observed) - center) - 1e-9;
  double hits = 0.0, all = 0.0;
  for (std::size_t sum = 0; sum < count[n0].size(); ++sum) {
    all += count[n0][sum];
    if (std::abs(static_cast<double>(sum) - center) >= distance) hits += count[n0][sum];
  }
  return hits / all;
}

}  // namespace

PermutationResult group_permutation_test(const std::vector<std::vector<double>>& groups,
                                         const PermutationOptions& options) {
  if (groups.size() < 2) {
    std::ostringstream m;
    m << "group permutation test: " << groups.size() << " group(s) (allowed: at least 2)";
    throw DataError(m.str());
  }
  std::vector<double> values;
  std::vector<int> labels;
  std::vector<double> sizes;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    if (groups[g].empty()) {
      std::ostringstream m;
      m << "group permutation test: group " << g + 1 << " has no participants (allowed: at least 1)";
      throw DataError(m.str());
    }
    for (double v : groups[g]) {
      if (!std::isfinite(v)) {
        std::ostringstream m;
        m << "group permutation test: group " << g + 1 << " has value " << v << " (allowed: finite)";
        throw DataError(m.str());
      }
      values.push_back(v);
      labels.push_back(static_cast<int>(g));
    }
    sizes.push_back(static_cast<double>(groups[g].size()));
  }
  if (options.monte_carlo < 1000) {
    std::ostringstream m;
    m << "group permutation test: monte_carlo = " << options.monte_carlo << " (allowed: >= 1000)";
    throw DataError(m.str());
  }
  const Ranking ranking = average_ranks(values);
  const double n = static_cast<double>(values.size());
  std::vector<double> sums(groups.size());
  const double observed = rank_statistic(ranking.ranks, labels, sums, sizes);
  const double tie_correction = 1.0 - ranking.tie_term / (n * n * n - n);
  PermutationResult result;
  result.h = tie_correction > 0.0 ? (12.0 / (n * (n + 1.0)) * observed - 3.0 * (n + 1.0)) / tie_correction : 0.0;

  // Distinct assignments: n! / prod n_g!, in logs to stay finite.
  double log_count = std::lgamma(n + 1.0);
  for (double s : sizes) log_count -= std::lgamma(s + 1.0);
  result.assignments = std::exp(log_count);
  if (result.assignments < 1e15) result.assignments = std::round(result.assignments);  // an integer count
  // Rounding of the floating sums: equal statistics must count as ties.
  const double tolerance = 1e-9 * std::max(1.0, std::abs(observed));
  std::size_t hits = 0;
  if (groups.size() == 2) {
    result.exact = true;
    result.evaluated = 0;  // counted, not enumerated
    result.p_value = two_group_exact_p(ranking.ranks, groups[0].size());
    result.p_interval = {result.p_value, result.p_value};
    return result;
  }
  if (result.assignments <= options.max_exact + 0.5) {
    std::vector<int> perm = labels;  // sorted already: groups were appended in order
    std::size_t count = 0;
    do {
      ++count;
      if (rank_statistic(ranking.ranks, perm, sums, sizes) >= observed - tolerance) ++hits;
    } while (std::next_permutation(perm.begin(), perm.end()));
    result.exact = true;
    result.evaluated = count;
    result.p_value = static_cast<double>(hits) / static_cast<double>(count);
    result.p_interval = {result.p_value, result.p_value};
    return result;
  }
  SplitMix64 rng(options.seed);
  std::vector<int> perm = labels;
  for (std::size_t d = 0; d < options.monte_carlo; ++d) {
    for (std::size_t i = perm.size() - 1; i > 0; --i) std::swap(perm[i], perm[rng.below(i + 1)]);
    if (rank_statistic(ranking.ranks, perm, sums, sizes) >= observed - tolerance) ++hits;
  }
  result.exact = false;
  result.evaluated = options.monte_carlo;
  result.p_value = static_cast<double>(hits + 1) / static_cast<double>(options.monte_carlo + 1);
  result.p_interval = wilson_interval(hits + 1, options.monte_carlo + 1);
  return result;
}

}  // namespace hapticlab::analysis::transfer
