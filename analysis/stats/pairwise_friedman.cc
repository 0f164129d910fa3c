#include "analysis/stats/pairwise_friedman.h"

#include <cmath>

#include "analysis/stats/data_error.h"
#include "analysis/stats/effect_size.h"
#include "analysis/stats/friedman.h"

namespace hapticlab::analysis {

double sidak_level(double alpha, std::size_t m) {
  if (!(alpha > 0.0 && alpha < 1.0)) {
    throw DataError("alpha is " + std::to_string(alpha) +
                    ", but must be > 0 and < 1");
  }
  if (m == 0) throw DataError("the Sidak level needs at least one comparison");
  // 1 − (1 − α)^(1/m), written with expm1/log1p to keep precision for small α
  return -std::expm1(std::log1p(-alpha) / static_cast<double>(m));
}

std::vector<PairwiseComparison> pairwise_friedman_vs_control(const BlockTable& table,
                                                             const std::string& control,
                                                             double alpha) {
  const std::size_t c = table.treatment_index(control);
  if (table.treatment_count() < 2) {
    throw DataError("only the control treatment '" + control +
                    "' is present; there is nothing to compare it with");
  }
  const double level = sidak_level(alpha, table.treatment_count() - 1);

  std::vector<PairwiseComparison> out;
  for (std::size_t t = 0; t < table.treatment_count(); ++t) {
    if (t == c) continue;
    PairwiseComparison cmp;
    cmp.treatment = table.treatment_names[t];
    const BalancedPair pair = balance_pair(table, c, t);
    cmp.replicates = pair.replicates;
    cmp.dropped_observations = pair.dropped;
    cmp.blocks_left_out = pair.blocks_left_out;
    cmp.n_blocks = pair.table.block_count();
    if (cmp.n_blocks > 0) {
      const TestResult r = friedman_test(pair.table);
      cmp.p = r.p;
      cmp.statistic = r.statistic;
      cmp.df = r.df;
      cmp.n_observations = r.observations;
      cmp.significant = r.p < level;
      cmp.rank_biserial = paired_rank_biserial(pair.table, pair.table.treatment_index(control),
                                               pair.table.treatment_index(cmp.treatment));
    }
    out.push_back(std::move(cmp));
  }
  return out;
}

}  // namespace hapticlab::analysis
