#include "analysis/stats/friedman.h"

#include <cmath>
#include <string>
#include <vector>

#include "analysis/stats/data_error.h"
#include "analysis/stats/distributions.h"
#include "analysis/stats/ranks.h"

namespace hapticlab::analysis {
namespace {

// Replicates per cell, after checking the layout is complete and balanced.
std::size_t balanced_replicates(const BlockTable& table) {
  if (table.block_count() < 1) throw DataError("Friedman test: no blocks");
  if (table.treatment_count() < 2) {
    throw DataError("Friedman test: " + std::to_string(table.treatment_count()) +
                    " treatment(s); at least 2 are needed");
  }
  const std::size_t reps = table.cells[0][0].size();
  for (std::size_t b = 0; b < table.block_count(); ++b) {
    for (std::size_t t = 0; t < table.treatment_count(); ++t) {
      const std::size_t n = table.cells[b][t].size();
      if (n == 0) {
        throw DataError("Friedman test: block '" + table.block_names[b] +
                        "' has no observation for treatment '" + table.treatment_names[t] +
                        "'; the Friedman test needs complete blocks (use the Skillings-Mack "
                        "test for missing cells)");
      }
      if (n != reps) {
        throw DataError("Friedman test: block '" + table.block_names[b] + "', treatment '" +
                        table.treatment_names[t] + "' has " + std::to_string(n) +
                        " observations but block '" + table.block_names[0] + "', treatment '" +
                        table.treatment_names[0] + "' has " + std::to_string(reps) +
                        "; every cell must hold the same number of replicates");
      }
      for (double v : table.cells[b][t]) {
        if (!std::isfinite(v)) {
          throw DataError("Friedman test: block '" + table.block_names[b] + "', treatment '" +
                          table.treatment_names[t] + "' holds a non-finite value");
        }
      }
    }
  }
  return reps;
}

}  // namespace

TestResult friedman_test(const BlockTable& table) {
  const std::size_t reps = balanced_replicates(table);
  const std::size_t k = table.treatment_count();
  const std::size_t b = table.block_count();
  const double n_per_block = static_cast<double>(reps * k);

  // Rank each block's r·k observations together; sum ranks per treatment.
  std::vector<double> rank_sums(k, 0.0);
  double tie_term = 0.0;
  std::vector<double> block_values;
  for (std::size_t i = 0; i < b; ++i) {
    block_values.clear();
    for (std::size_t t = 0; t < k; ++t) {
      block_values.insert(block_values.end(), table.cells[i][t].begin(), table.cells[i][t].end());
    }
    const Ranking ranking = average_ranks(block_values);
    for (std::size_t t = 0; t < k; ++t) {
      for (std::size_t r = 0; r < reps; ++r) rank_sums[t] += ranking.ranks[t * reps + r];
    }
    tie_term += ranking.tie_term;
  }

  // Q = Σ (R_j − E)² / (b r σ²), σ² tie-corrected (see header).
  const double bd = static_cast<double>(b);
  const double rd = static_cast<double>(reps);
  const double expected = bd * rd * (n_per_block + 1.0) / 2.0;
  double squares = 0.0;
  for (double r : rank_sums) squares += (r - expected) * (r - expected);
  const double sigma_sq = n_per_block * (n_per_block + 1.0) / 12.0 -
                          tie_term / (12.0 * bd * (n_per_block - 1.0));

  TestResult result;
  result.method = reps > 1 ? "Friedman (replicates ranked within block)" : "Friedman";
  result.df = static_cast<double>(k - 1);
  result.blocks = b;
  result.treatments = k;
  result.observations = b * reps * k;
  // Every block entirely tied: no information, and σ² is 0 (up to rounding).
  const bool degenerate = sigma_sq <= 1e-12 * n_per_block * (n_per_block + 1.0);
  result.statistic = degenerate ? 0.0 : squares / (bd * rd * sigma_sq);
  result.p = chi_squared_upper(result.statistic, result.df);
  return result;
}

}  // namespace hapticlab::analysis
