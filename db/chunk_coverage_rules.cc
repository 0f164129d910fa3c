#include "db/chunk_coverage_rules.h"

#include <utility>

namespace hapticlab::db {
namespace {

BadChunk missing(std::int64_t trial_id, std::int64_t instrument, std::int64_t first_tick, std::int64_t count,
                 std::string why) {
  return {trial_id, instrument, first_tick, count, ChunkError::Kind::kPlacement, std::move(why)};
}

constexpr std::int64_t kLastUpdateUnpublished = 1;

}  // namespace

LoopCount loop_count(std::int64_t periods, std::int64_t rejected, std::int64_t dropped) {
  LoopCount c;
  if (periods < 0 || rejected < 0 || dropped < 0) return c;  // the value checks name these
  if (periods + rejected == 0) return c;
  c.known = true;
  c.ticks = periods + rejected + 1;
  c.dropped = dropped;
  return c;
}

// A study-API trial whose ticks go up by 2 has one gap per sample: the
// lengths are counted (a map), so matching is O(gaps log lengths), not
// gaps x events.
std::string logged_gaps_sql(const std::string& schema) {
  return "SELECT item_index FROM " + schema +
         ".event WHERE trial_id = ?1 AND type = 'samples_missing' AND typeof(item_index) = 'integer'";
}

std::string loop_count_sql(const std::string& schema) {
  return "SELECT count, rejected_periods, dropped_samples FROM " + schema +
         ".loop_timing WHERE trial_id = ?1 AND typeof(count) = 'integer' AND "
         "typeof(rejected_periods) = 'integer' AND typeof(dropped_samples) = 'integer'";
}

void add_coverage_findings(std::int64_t trial_id, const ChunkLayout& layout,
                           const std::map<std::int64_t, std::int64_t>& logged, const LoopCount& loop,
                           std::vector<BadChunk>& bad) {
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
