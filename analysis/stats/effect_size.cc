#include "analysis/stats/effect_size.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {

double kendalls_w(double friedman_chi2, std::size_t blocks, std::size_t treatments, std::size_t replicates) {
  if (blocks < 1 || treatments < 2 || replicates < 1) {
    throw DataError("Kendall's W needs at least 1 block, 2 settings and 1 replicate, got " + std::to_string(blocks) +
                    " blocks, " + std::to_string(treatments) + " settings and " + std::to_string(replicates) +
                    " replicates");
  }
  const double b = static_cast<double>(blocks);
  const double k = static_cast<double>(treatments);
  const double r = static_cast<double>(replicates);
  return friedman_chi2 * (r * k + 1.0) / (b * r * r * (k * k - 1.0));
}

double matched_pairs_rank_biserial(const std::vector<double>& differences) {
  std::vector<double> nonzero;
  for (double d : differences) {
    if (!std::isfinite(d)) throw DataError("a paired difference is not a finite number (" + std::to_string(d) + ")");
    if (d != 0.0) nonzero.push_back(d);
  }
  if (nonzero.empty()) return 0.0;
  std::vector<std::size_t> order(nonzero.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return std::abs(nonzero[a]) < std::abs(nonzero[b]); });
  double positive = 0.0;
  double negative = 0.0;
  for (std::size_t i = 0; i < order.size();) {
    std::size_t j = i;
    while (j < order.size() && std::abs(nonzero[order[j]]) == std::abs(nonzero[order[i]])) ++j;
    const double rank = (static_cast<double>(i + 1) + static_cast<double>(j)) / 2.0;  // average of i+1..j
    for (std::size_t m = i; m < j; ++m) (nonzero[order[m]] > 0 ? positive : negative) += rank;
    i = j;
  }
  return (positive - negative) / (positive + negative);
}

double paired_rank_biserial(const BlockTable& table, std::size_t control, std::size_t treatment) {
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  };
  std::vector<double> differences;
  for (const auto& row : table.cells) {
    if (row.at(control).empty() || row.at(treatment).empty()) continue;
    differences.push_back(median(row[treatment]) - median(row[control]));
  }
  if (differences.empty()) throw DataError("rank-biserial r: no block has values under both settings");
  return matched_pairs_rank_biserial(differences);
}

}  // namespace hapticlab::analysis
