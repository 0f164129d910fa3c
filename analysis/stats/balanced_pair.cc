#include "analysis/stats/balanced_pair.h"

#include <algorithm>
#include <utility>
#include <vector>

namespace hapticlab::analysis {

std::string balancing_note(std::size_t replicates, std::size_t dropped,
                           std::size_t blocks_left_out) {
  if (dropped == 0) return {};
  std::string out = "balanced to " + std::to_string(replicates) + " repetition(s) per cell: " +
                    std::to_string(dropped) + " observation(s) dropped";
  if (blocks_left_out > 0) out += ", " + std::to_string(blocks_left_out) + " block(s) left out";
  return out;
}

BalancedPair balance_pair(const BlockTable& table, std::size_t first, std::size_t second) {
  BalancedPair out;
  out.table.treatment_names = {table.treatment_names.at(first), table.treatment_names.at(second)};

  // Blocks holding both treatments, with the replicates both cells can give.
  std::vector<std::pair<std::size_t, std::size_t>> usable;  // block, min(replicates)
  for (std::size_t b = 0; b < table.block_count(); ++b) {
    const auto& c1 = table.cells[b][first];
    const auto& c2 = table.cells[b][second];
    if (c1.empty() || c2.empty()) continue;
    usable.emplace_back(b, std::min(c1.size(), c2.size()));
    out.available += c1.size() + c2.size();
  }

  // r = each block's own count in turn; keeping r per cell keeps 2·r values in
  // every block that has at least r.
  std::size_t r = 0;
  std::size_t best_kept = 0;
  for (const auto& [block, reps] : usable) {
    std::size_t blocks_with = 0;
    for (const auto& other : usable) blocks_with += other.second >= reps ? 1 : 0;
    const std::size_t kept = 2 * reps * blocks_with;
    if (kept > best_kept || (kept == best_kept && reps < r)) {
      best_kept = kept;
      r = reps;
    }
  }

  const auto first_r = [&](const std::vector<double>& v) {
    return std::vector<double>(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(r));
  };
  for (const auto& [b, reps] : usable) {
    if (reps < r) {
      ++out.blocks_left_out;
      continue;
    }
    out.table.block_names.push_back(table.block_names[b]);
    out.table.cells.push_back({first_r(table.cells[b][first]), first_r(table.cells[b][second])});
  }
  out.replicates = r;
  out.dropped = out.available - best_kept;
  return out;
}

}  // namespace hapticlab::analysis
