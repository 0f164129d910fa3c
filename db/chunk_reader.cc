#include "db/chunk_reader.h"

namespace hapticlab::db {
namespace {

BadChunk bad_chunk(std::int64_t trial_id, int instrument, std::uint64_t first_tick, std::int64_t count,
                   const ChunkError& e) {
  return {trial_id, instrument, first_tick, static_cast<std::uint64_t>(count), e.kind(), e.what()};
}

}  // namespace

std::string describe(const BadChunk& c) {
  const char* hand = c.instrument == 0 ? "left" : c.instrument == 1 ? "right" : "unknown";
  std::string ticks = std::to_string(c.first_tick);
  if (c.count > 1) ticks += ".." + std::to_string(c.first_tick + c.count - 1);
  return "trial " + std::to_string(c.trial_id) + ", " + hand + " instrument (" + std::to_string(c.instrument) +
         "), ticks " + ticks + ": " + c.problem;
}

void for_each_chunk(Database& db, std::int64_t trial_id, int instrument, std::vector<StoredSample>& scratch,
                    const std::function<void(std::span<const StoredSample>)>& on_chunk,
                    std::vector<BadChunk>& bad) {
  Statement s = db.prepare(
      "SELECT first_tick, count, data FROM sample_chunk WHERE trial_id = ?1 AND instrument = ?2 ORDER BY first_tick");
  s.bind(1, trial_id).bind(2, std::int64_t{instrument});
  while (s.step()) {
    const auto first = static_cast<std::uint64_t>(s.column_int64(0));
    const std::int64_t count = s.column_int64(1);
    scratch.clear();
    try {
      decode_chunk(first, static_cast<std::size_t>(count), s.column_blob(2), scratch);
    } catch (const ChunkError& e) {
      bad.push_back(bad_chunk(trial_id, instrument, first, count, e));
      continue;
    }
    on_chunk(scratch);
  }
}

void read_samples(Database& db, std::int64_t trial_id, int instrument, std::vector<StoredSample>& out,
                  std::vector<BadChunk>& bad) {
  std::vector<StoredSample> scratch;
  for_each_chunk(db, trial_id, instrument, scratch,
                 [&](std::span<const StoredSample> chunk) { out.insert(out.end(), chunk.begin(), chunk.end()); },
                 bad);
}

ChunkCheck check_all_chunks(Database& db) {
  ChunkCheck result;
  Statement s = db.prepare(
      "SELECT trial_id, instrument, first_tick, count, data FROM sample_chunk "
      "ORDER BY trial_id, instrument, first_tick");
  std::vector<StoredSample> scratch;
  while (s.step()) {
    ++result.chunks;
    const std::int64_t trial_id = s.column_int64(0);
    const int instrument = static_cast<int>(s.column_int64(1));
    const auto first = static_cast<std::uint64_t>(s.column_int64(2));
    const std::int64_t count = s.column_int64(3);
    scratch.clear();
    try {
      const std::span<const std::byte> blob = s.column_blob(4);
      decode_chunk(first, static_cast<std::size_t>(count), blob, scratch);
      result.updates += scratch.size();
      if (std::to_integer<std::uint8_t>(blob[0]) == kChunkFormatMigrated) ++result.migrated_chunks;
    } catch (const ChunkError& e) {
      result.bad.push_back(bad_chunk(trial_id, instrument, first, count, e));
    }
  }
  return result;
}

}  // namespace hapticlab::db
