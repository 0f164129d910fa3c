#pragma once
// Whether a trial's well-placed chunks (chunk_layout.h) hold every update
// the loop stored, so that a removed chunk is found, not read as a shorter
// trial. What the file itself says the trial had:
//   - the writer leaves a gap between two chunks only where updates never
//     reached it, and logs each such gap as a samples_missing event whose
//     item_index is its length: every gap between an instrument's chunks
//     must be one of those events;
//   - loop_timing (when its count and rejected_periods are integers: not in
//     rows migrated from version 1) gives the updates the loop ran
//     (count + rejected_periods + 1 ticks, from tick 0) and dropped_samples
//     those it could not queue: the chunks of each instrument must hold the
//     rest, from tick 0 to the end, but for the last update (a trial that
//     ends on a fault or a stop counts the period of an update whose sample
//     it never published; a removed last chunk of a single update is thus
//     not found).
// Each shortfall is added to `bad` as a missing range of the instrument
// (ChunkError::Kind::kPlacement), e.g. "ticks 1000..1999 are not stored,
// and no samples_missing event accounts for them (a chunk was removed)".
// The rules themselves, without SQLite, are in chunk_coverage_rules.h
// (the SQL extension applies them too).
#include <cstdint>
#include <vector>

#include "db/chunk_layout.h"
#include "db/sqlite_handle.h"

namespace hapticlab::db {

// `layout`: the trial's rows of both instruments as layout_chunks gave
// them; call only when that found no bad row for the trial (a misplaced
// chunk already makes it damaged, and its ticks would be counted twice).
// `schema`: the attached database the rows come from ("main").
void check_chunk_coverage(Database& db, std::int64_t trial_id, const ChunkLayout& layout, std::vector<BadChunk>& bad,
                          const char* schema = "main");

}  // namespace hapticlab::db
