#pragma once
// Where a trial's sample chunks are, checked from their rows before any
// blob is read: per trial and instrument, every chunk has a known
// instrument (0 or 1), a first tick >= 0, a count of 1..kMaxChunkUpdates,
// integer columns and a BLOB, and no two chunks of one instrument share a
// tick (their ticks never overlap, so a reader never meets a tick twice or
// a tick going backwards). Gaps are allowed here: the writer leaves one,
// with a samples_missing event, when the loop could not queue updates
// (chunk_coverage.h checks each gap against those events, and the chunks
// against the updates the loop ran).
//
// A chunk that breaks a rule is bad, named with its trial, instrument and
// ticks (BadChunk); of two overlapping chunks both are, since nothing tells
// which one is right. Pure logic over the rows' values: the SQL extension
// (db/sqlite_extension/), which reads rows through its host's SQLite, uses
// it as the library's readers do (chunk_reader.h).

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "db/sample_codec.h"

namespace hapticlab::db {

// A chunk that cannot be used: its checksum, format, structure or place.
// The tick range is the row's (first_tick .. first_tick + count - 1).
struct BadChunk {
  std::int64_t trial_id = 0;
  std::int64_t instrument = 0;  // 0 left, 1 right; anything else is itself the damage
  std::int64_t first_tick = 0;
  std::int64_t count = 0;
  ChunkError::Kind kind = ChunkError::Kind::kChecksum;
  std::string problem;  // the ChunkError's message, or the layout rule broken
};

// "1000..1999" (one tick: "1000").
std::string tick_range(std::int64_t first_tick, std::int64_t count);
// "trial 3, left instrument (0), ticks 1000..1999".
std::string chunk_name(std::int64_t trial_id, std::int64_t instrument, std::int64_t first_tick, std::int64_t count);
// chunk_name(...) + ": " + problem.
std::string describe(const BadChunk& chunk);

// One sample_chunk row as read for the layout check, without its blob.
struct ChunkRow {
  std::int64_t id = 0;
  std::int64_t trial_id = 0;
  std::int64_t instrument = 0;
  std::int64_t first_tick = 0;
  std::int64_t count = 0;
  // typeof() of trial_id, instrument, first_tick, count, data, and quote()
  // of the first four (for the message), as SQLite gives them.
  std::string types[5];
  std::string values[4];

  ChunkPlace place() const noexcept {
    return {trial_id, instrument, static_cast<std::uint64_t>(first_tick), static_cast<std::uint64_t>(count)};
  }
};

// The SQL that reads a trial's rows for layout_chunks: columns id,
// trial_id, instrument, first_tick, count, the five typeof() and the four
// quote() of ChunkRow, in that order; parameter ?1 the trial. Goes through
// the unique index on (trial_id, instrument, first_tick); reads no blob.
std::string chunk_rows_sql(const char* schema = "main");

// Splits `rows` (one trial's, in any order) into the good rows of
// instrument 0 and of instrument 1, each in tick order, and the bad ones,
// appended to `bad` (kPlacement) in (instrument, first tick) order.
struct ChunkLayout {
  std::vector<ChunkRow> instrument[2];
  std::size_t updates[2] = {0, 0};  // the good rows' counts, summed
};
ChunkLayout layout_chunks(std::vector<ChunkRow> rows, std::vector<BadChunk>& bad);

}  // namespace hapticlab::db
