#pragma once
// Reading sample chunks so that a damaged one is left out and named, never
// decoded into wrong numbers: every read path (export, analysis, replay,
// `study check`) goes through decode_chunk, which verifies the checksum
// (sample_codec.h) first.

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "db/sample_codec.h"
#include "db/sqlite_handle.h"

namespace hapticlab::db {

// A chunk that failed its checksum, format or structure check. The tick
// range is the row's (first_tick .. first_tick + count - 1).
struct BadChunk {
  std::int64_t trial_id = 0;
  int instrument = 0;  // 0 left, 1 right
  std::uint64_t first_tick = 0;
  std::uint64_t count = 0;
  ChunkError::Kind kind = ChunkError::Kind::kChecksum;
  std::string problem;  // the ChunkError's message
};

// "trial 3, left instrument (0), ticks 1000..1999: checksum mismatch (...)".
std::string describe(const BadChunk& chunk);

// Every good chunk of (trial, instrument) in tick order, decoded into
// `scratch` (cleared first, so a reader holds one chunk at a time) and
// handed to `on_chunk`; a chunk that fails is left out and appended to
// `bad`. Throws DbError only for the database itself.
void for_each_chunk(Database& db, std::int64_t trial_id, int instrument, std::vector<StoredSample>& scratch,
                    const std::function<void(std::span<const StoredSample>)>& on_chunk,
                    std::vector<BadChunk>& bad);

// for_each_chunk, every sample appended to `out`.
void read_samples(Database& db, std::int64_t trial_id, int instrument, std::vector<StoredSample>& out,
                  std::vector<BadChunk>& bad);

struct ChunkCheck {
  std::uint64_t chunks = 0;           // chunks checked
  std::uint64_t updates = 0;          // updates in the good ones
  std::uint64_t migrated_chunks = 0;  // good format 0 chunks: checksummed at migration, not when written
  std::vector<BadChunk> bad;
};

// Verifies and decodes (then discards) every chunk of the file, one at a
// time, in (trial, instrument, tick) order.
ChunkCheck check_all_chunks(Database& db);

}  // namespace hapticlab::db
