#pragma once
// Which settings each participant does.
//
// Complete design: everyone does every setting. Incomplete design (thesis
// Table 3.2): everyone does the `required` settings plus k of the m others
// (the optional ones), chosen so that
//   1. each optional setting is done by as equal a number of participants as
//      possible (counts differ by at most 1), then
//   2. each pair of optional settings is done together by as equal a number
//      of participants as possible (smallest max - min of the pair counts),
// so that every comparison between two settings rests on similar numbers of
// participants. Explicit design: the table is given (thesis Table 3.3).

#include <cstddef>
#include <cstdint>
#include <vector>

#include "protocols/protocol.h"

namespace hapticlab::protocols {

// How evenly a set of k-subsets of {0..m-1} covers the m items and pairs.
struct DesignBalance {
  std::vector<int> item_counts;               // [a]: subsets containing a
  std::vector<std::vector<int>> pair_counts;  // [a][b], a != b: subsets containing both; symmetric
  int item_spread = 0;  // max - min of item_counts (0 if m == 0)
  int pair_spread = 0;  // max - min of pair_counts over a < b (0 if m < 2)
};

// `subsets` holds item indices < m, each subset without repeats.
DesignBalance design_balance(const std::vector<std::vector<std::size_t>>& subsets, std::size_t m);

// The ideal a design of n k-subsets of m items could reach: item spread
// 0 when m divides n·k, else 1; pair spread 0 when C(m,2) divides n·C(k,2),
// else 1. (Whether the ideal pair spread exists depends on combinatorics: a
// balanced incomplete block design need not exist.)
int ideal_item_spread(std::size_t n, std::size_t m, std::size_t k);
int ideal_pair_spread(std::size_t n, std::size_t m, std::size_t k);

// n k-subsets of {0..m-1} (each sorted ascending), one per participant,
// balanced as described above; 0 <= k <= m. Deterministic given `seed`:
// a seeded local search (moves: swap one item of a subset for one outside
// it; exchange items between two subsets), minimizing, in this order,
// (item spread, sum of squared item counts, pair spread, sum of squared pair
// counts), from up to 64 seeded starts, stopping early at the ideal. The
// item spread it returns is always the ideal.
std::vector<std::vector<std::size_t>> balanced_subsets(std::size_t n, std::size_t m, std::size_t k,
                                                       std::uint64_t seed);

// The settings of every participant, in Protocol::participants order: indices
// into Protocol::settings, ascending (protocol order). The protocol must be
// valid (validate_protocol). Incomplete designs use balanced_subsets with the
// stream "design" of the protocol's seed.
std::vector<std::vector<std::size_t>> assign_settings(const Protocol& protocol);

}  // namespace hapticlab::protocols
