#include "db/chunk_layout.h"

#include <algorithm>
#include <limits>

namespace hapticlab::db {
namespace {

constexpr const char* kColumns[5] = {"trial_id", "instrument", "first_tick", "count", "data"};

// Why the row's columns cannot place it, or "": integers where integers
// belong and a BLOB for the data.
std::string type_problem(const ChunkRow& r) {
  std::string out;
  for (int c = 0; c < 5; ++c) {
    const std::string want = c == 4 ? "blob" : "integer";
    if (r.types[c] == want) continue;
    out += (out.empty() ? "" : "; ") + std::string("its ") + kColumns[c] + " is " + r.types[c] +
           (c < 4 && r.types[c] != "null" ? " " + r.values[c] : std::string()) + ", expected " +
           (c == 4 ? "a BLOB" : "an INTEGER");
  }
  return out;
}

// Why the row cannot be a chunk of its trial on its own, or "".
std::string row_problem(const ChunkRow& r) {
  if (std::string types = type_problem(r); !types.empty()) return types;
  if (r.instrument != 0 && r.instrument != 1)
    return "instrument " + std::to_string(r.instrument) + " is neither 0 (left) nor 1 (right)";
  if (r.first_tick < 0) return "first tick " + std::to_string(r.first_tick) + " is negative";
  if (r.count < 1 || r.count > static_cast<std::int64_t>(kMaxChunkUpdates))
    return "count is " + std::to_string(r.count) + ", must be 1.." + std::to_string(kMaxChunkUpdates);
  if (r.first_tick > std::numeric_limits<std::int64_t>::max() - r.count)
    return "its ticks run past the largest tick (2^63 - 1)";
  return {};
}

BadChunk bad_row(const ChunkRow& r, std::string problem) {
  return {r.trial_id, r.instrument, r.first_tick, r.count, ChunkError::Kind::kPlacement, std::move(problem)};
}

}  // namespace

std::string tick_range(std::int64_t first_tick, std::int64_t count) {
  std::string ticks = std::to_string(first_tick);
  if (count > 1 && first_tick <= std::numeric_limits<std::int64_t>::max() - (count - 1))
    ticks += ".." + std::to_string(first_tick + count - 1);
  return ticks;
}

std::string chunk_name(std::int64_t trial_id, std::int64_t instrument, std::int64_t first_tick, std::int64_t count) {
  const char* hand = instrument == 0 ? "left" : instrument == 1 ? "right" : "unknown";
  return "trial " + std::to_string(trial_id) + ", " + hand + " instrument (" + std::to_string(instrument) +
         "), ticks " + tick_range(first_tick, count);
}

std::string describe(const BadChunk& c) {
  return chunk_name(c.trial_id, c.instrument, c.first_tick, c.count) + ": " + c.problem;
}

std::string chunk_rows_sql(const char* schema) {
  return std::string(
             "SELECT id, trial_id, instrument, first_tick, count, typeof(trial_id), typeof(instrument), "
             "typeof(first_tick), typeof(count), typeof(data), quote(trial_id), quote(instrument), "
             "quote(first_tick), quote(count) FROM ") +
         schema + ".sample_chunk WHERE trial_id = ?1 ORDER BY instrument, first_tick, id";
}

ChunkLayout layout_chunks(std::vector<ChunkRow> rows, std::vector<BadChunk>& bad) {
  std::sort(rows.begin(), rows.end(), [](const ChunkRow& a, const ChunkRow& b) {
    if (a.instrument != b.instrument) return a.instrument < b.instrument;
    if (a.first_tick != b.first_tick) return a.first_tick < b.first_tick;
    return a.id < b.id;
  });
  std::vector<std::string> problem(rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) problem[i] = row_problem(rows[i]);
  // Overlaps within an instrument, among rows that are fine on their own:
  // in tick order, a chunk that starts before the furthest end so far
  // shares ticks with the chunk that reached it; both are in doubt.
  std::size_t reach = rows.size();  // the row whose end is furthest, in this instrument
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (!problem[i].empty()) continue;
    const ChunkRow& r = rows[i];
    if (reach < rows.size() && rows[reach].instrument != r.instrument) reach = rows.size();
    if (reach < rows.size()) {
      const ChunkRow& p = rows[reach];
      const std::int64_t p_end = p.first_tick + p.count;  // one past its last tick
      if (r.first_tick < p_end) {
        problem[i] = "its ticks overlap those of the chunk with ticks " + tick_range(p.first_tick, p.count) +
                     " (a tick stored twice)";
        if (problem[reach].empty())
          problem[reach] = "its ticks overlap those of the chunk with ticks " + tick_range(r.first_tick, r.count) +
                           " (a tick stored twice)";
      }
      if (r.first_tick + r.count <= p_end) continue;  // reach stays
    }
    reach = i;
  }
  ChunkLayout out;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (!problem[i].empty()) {
      bad.push_back(bad_row(rows[i], std::move(problem[i])));
      continue;
    }
    const auto k = static_cast<std::size_t>(rows[i].instrument);
    out.updates[k] += static_cast<std::size_t>(rows[i].count);
    out.instrument[k].push_back(std::move(rows[i]));
  }
  return out;
}

}  // namespace hapticlab::db
