#pragma once
// Two treatments of a block design made fit for the replicated Friedman test
// (MATLAB friedman(X, reps)), which needs the same number of replicates in
// every cell. A time-out or a hand without contact leaves a cell short, so:
// only blocks holding both treatments are used; every such block keeps its
// first r replicates of each treatment, with r chosen to keep the most
// observations (on a tie, the smaller r, which keeps more blocks); a block
// with fewer than r replicates in either cell is left out.
//
// Used by `stats pairwise` and by the study analysis (Tables 3.5 / 3.6), so
// both balance the same way.
#include <cstddef>
#include <string>

#include "analysis/stats/block_table.h"

namespace hapticlab::analysis {

// "balanced to 2 repetition(s) per cell: 3 observation(s) dropped, 1 block(s)
// left out", or empty when nothing was dropped.
std::string balancing_note(std::size_t replicates, std::size_t dropped,
                           std::size_t blocks_left_out);

struct BalancedPair {
  // Treatments {first, second}; the blocks kept, in table order, r values each.
  BlockTable table;
  std::size_t replicates = 0;       // r (0 when no block holds both)
  std::size_t available = 0;        // observations in the blocks holding both
  std::size_t dropped = 0;          // available minus those kept
  std::size_t blocks_left_out = 0;  // blocks holding both but fewer than r in a cell

  std::string note() const { return balancing_note(replicates, dropped, blocks_left_out); }
};

// first, second: treatment indices in `table`, different.
BalancedPair balance_pair(const BlockTable& table, std::size_t first, std::size_t second);

}  // namespace hapticlab::analysis
