#pragma once
// The rules of chunk_coverage.h without the queries: what a trial's
// well-placed chunks must hold, given the samples_missing gaps its writer
// logged and what its loop_timing row says the loop ran. No SQLite here:
// the SQL extension (which calls its host's SQLite) asks the same
// questions through its own statements and applies the same rules.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "db/chunk_layout.h"

namespace hapticlab::db {

// What loop_timing says about a trial's updates.
struct LoopCount {
  bool known = false;        // false: no row, or one that cannot tell (below)
  std::int64_t ticks = 0;    // updates the loop ran (tick 0 .. ticks - 1)
  std::int64_t dropped = 0;  // of those, never queued to the writer
};
// From a row's count, rejected_periods and dropped_samples (integers). A
// negative value (the value checks name it) or no period at all (the loop
// ran one update or none, which the count cannot tell apart) is not known.
LoopCount loop_count(std::int64_t periods, std::int64_t rejected, std::int64_t dropped);

// The queries, with the trial's id as ?1: the item_index (a gap's length)
// of each samples_missing event; the loop_timing row's count,
// rejected_periods and dropped_samples when all three are integers.
std::string logged_gaps_sql(const std::string& schema);
std::string loop_count_sql(const std::string& schema);

// Adds each shortfall of `layout` (the trial's rows of both instruments,
// as layout_chunks gave them without a bad row) to `bad`. `logged`: how
// many samples_missing gaps of each length.
void add_coverage_findings(std::int64_t trial_id, const ChunkLayout& layout,
                           const std::map<std::int64_t, std::int64_t>& logged, const LoopCount& loop,
                           std::vector<BadChunk>& bad);

}  // namespace hapticlab::db
