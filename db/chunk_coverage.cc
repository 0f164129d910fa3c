#include "db/chunk_coverage.h"

#include <map>
#include <string>

namespace hapticlab::db {
namespace {

BadChunk missing(std::int64_t trial_id, std::int64_t instrument, std::int64_t first_tick, std::int64_t count,
                 std::string why) {
  return {trial_id, instrument, first_tick, count, ChunkError::Kind::kPlacement, std::move(why)};
}

// The lengths of the samples_missing gaps the writer logged, and how many
// of each (a study-API trial whose ticks go up by 2 has one per sample:
// matched in O(gaps log lengths), not gaps x events).
std::map<std::int64_t, std::int64_t> logged_gaps(Database& db, std::int64_t trial_id, const std::string& schema) {
  Statement s = db.prepare("SELECT item_index FROM " + schema +
                           ".event WHERE trial_id = ?1 AND type = 'samples_missing' AND typeof(item_index) = 'integer'");
  s.bind(1, trial_id);
  std::map<std::int64_t, std::int64_t> out;
  while (s.step()) ++out[s.column_int64(0)];
  return out;
}

constexpr std::int64_t kLastUpdateUnpublished = 1;

struct LoopCount {
  bool known = false;
  std::int64_t ticks = 0;    // updates the loop ran (tick 0 .. ticks - 1)
  std::int64_t dropped = 0;  // of those, never queued to the writer
};

LoopCount loop_count(Database& db, std::int64_t trial_id, const std::string& schema) {
  Statement s = db.prepare("SELECT count, rejected_periods, dropped_samples FROM " + schema +
                           ".loop_timing WHERE trial_id = ?1 AND typeof(count) = 'integer' AND "
                           "typeof(rejected_periods) = 'integer' AND typeof(dropped_samples) = 'integer'");
  s.bind(1, trial_id);
  LoopCount c;
  if (!s.step()) return c;
  const std::int64_t periods = s.column_int64(0), rejected = s.column_int64(1);
  c.dropped = s.column_int64(2);
  if (periods < 0 || rejected < 0 || c.dropped < 0) return c;  // the value checks name these
  // No period: the loop ran one update or none (it never started), which
  // the count cannot tell apart.
  if (periods + rejected == 0) return c;
  c.known = true;
  c.ticks = periods + rejected + 1;
  return c;
}

}  // namespace

void check_chunk_coverage(Database& db, std::int64_t trial_id, const ChunkLayout& layout, std::vector<BadChunk>& bad,
                          const char* schema) {
  const std::map<std::int64_t, std::int64_t> logged = logged_gaps(db, trial_id, schema);
  const LoopCount loop = loop_count(db, trial_id, schema);
  for (std::int64_t k = 0; k < 2; ++k) {
    const std::vector<ChunkRow>& rows = layout.instrument[k];
    std::map<std::int64_t, std::int64_t> unexplained = logged;  // each logged gap explains one gap of its length
    std::int64_t reported = 0;
    for (std::size_t i = 1; i < rows.size(); ++i) {
      const std::int64_t from = rows[i - 1].first_tick + rows[i - 1].count, length = rows[i].first_tick - from;
      if (length <= 0) continue;
      if (const auto it = unexplained.find(length); it != unexplained.end() && it->second > 0) {
        --it->second;
        continue;
      }
      reported += length;
      bad.push_back(missing(trial_id, k, from, length,
                            "not stored, and no samples_missing event accounts for them (a chunk was removed)"));
    }
    if (!loop.known) continue;
    // Undamaged, the chunks hold every update the loop ran but those it
    // could not queue: those between chunks are the logged gaps, the rest
    // were at the start or the end.
    const std::int64_t stored = static_cast<std::int64_t>(layout.updates[k]);
    // One update short is not damage: a trial that ends on a fault or a
    // stop counts the period of its last update, whose sample it never
    // published (kLastUpdateUnpublished).
    const std::int64_t short_by = loop.ticks - loop.dropped - stored - reported;
    if (short_by <= kLastUpdateUnpublished) continue;
    const std::string ran = "the loop ran " + std::to_string(loop.ticks) + " updates (ticks 0.." +
                            std::to_string(loop.ticks - 1) + ") and could not queue " + std::to_string(loop.dropped) +
                            ", but the chunks hold " + std::to_string(stored) + " (a chunk was removed)";
    const std::int64_t first = rows.empty() ? loop.ticks : rows.front().first_tick;
    const std::int64_t end = rows.empty() ? 0 : rows.back().first_tick + rows.back().count;
    if (loop.dropped > 0) {
      // Which of them were lost, and which removed, is not known: the
      // trial's whole range is named, with the count.
      bad.push_back(missing(trial_id, k, 0, loop.ticks, std::to_string(short_by) + " of them not stored: " + ran));
      continue;
    }
    if (rows.empty()) {
      bad.push_back(missing(trial_id, k, 0, loop.ticks, "not stored: " + ran));
      continue;
    }
    if (first > 0) bad.push_back(missing(trial_id, k, 0, first, "not stored: " + ran));
    if (end < loop.ticks - kLastUpdateUnpublished)
      bad.push_back(missing(trial_id, k, end, loop.ticks - end, "not stored: " + ran));
  }
}

}  // namespace hapticlab::db
