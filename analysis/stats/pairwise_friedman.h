#pragma once
// The thesis' pairwise comparisons against a control (3.3.7.1, 3.4.2.1,
// Tables 3.5 and 3.6): for each other treatment, a Friedman test (replicates
// ranked within block) over every block that holds data for both the control
// and that treatment, judged at the Šidák level 1 − (1 − α)^(1/m) for m
// comparisons (0.0073 for m = 7, α = 0.05).
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "analysis/stats/balanced_pair.h"
#include "analysis/stats/block_table.h"

namespace hapticlab::analysis {

struct PairwiseComparison {
  std::string treatment;        // compared with the control
  std::optional<double> p;      // nullopt: no block holds both ("N/A" in the thesis)
  std::optional<double> statistic;
  std::optional<double> df;     // 1 (two treatments) when tested
  std::size_t n_blocks = 0;     // blocks that entered the test
  std::size_t n_observations = 0;  // values in those blocks, both cells, all replicates
  bool significant = false;     // p < sidak_level
  // Effect size over the same blocks (effect_size.h paired_rank_biserial):
  // +1 every block higher under the treatment than the control, -1 lower.
  std::optional<double> rank_biserial;
  // Balancing (see balanced_pair.h): replicates per cell, and what was left
  // out to reach them.
  std::size_t replicates = 0;
  std::size_t dropped_observations = 0;
  std::size_t blocks_left_out = 0;
};

// 1 − (1 − alpha)^(1/m); alpha in (0, 1), m >= 1. Throws DataError otherwise.
double sidak_level(double alpha, std::size_t m);

// Compares `control` (a treatment name in table) with every other treatment,
// in table order; m is the number of other treatments. Blocks missing either
// cell are left out of that comparison, and the rest are balanced to equal
// replicates with balance_pair(), as the study analysis does.
std::vector<PairwiseComparison> pairwise_friedman_vs_control(const BlockTable& table,
                                                             const std::string& control,
                                                             double alpha = 0.05);

}  // namespace hapticlab::analysis
