#include "db/replay_frames.h"

#include <algorithm>
#include <array>
#include <limits>
#include <string>

#include "db/chunk_reader.h"

namespace hapticlab::db {

std::vector<ReplayFrame> load_replay_frames(StudyDb& db, std::int64_t trial_id) {
  db.trial(trial_id);  // throws, naming the trial, if there is none
  std::array<std::vector<StoredSample>, 2> stored;
  std::vector<BadChunk> bad;
  for (int k = 0; k < 2; ++k) read_samples(db.connection(), trial_id, k, stored[static_cast<std::size_t>(k)], bad);
  if (!bad.empty()) {
    std::string list;
    for (const BadChunk& c : bad) list += "; " + describe(c);
    throw DbError(db.path() + ": trial " + std::to_string(trial_id) + " cannot be replayed: " +
                  std::to_string(bad.size()) + " damaged sample chunk(s)" + list);
  }
  if (stored[0].empty() && stored[1].empty())
    throw DbError(db.path() + ": trial " + std::to_string(trial_id) +
                  " has no stored samples, so there is nothing to replay (has it run?)");

  // Each instrument's position before its first stored update.
  std::array<DeviceJoints, 2> latest{};
  for (std::size_t k = 0; k < 2; ++k)
    if (!stored[k].empty()) latest[k] = stored[k].front().value.raw_position;

  // Merge the two tick-ordered lists: one frame per tick.
  std::vector<ReplayFrame> frames;
  frames.reserve(std::max(stored[0].size(), stored[1].size()));
  std::array<std::size_t, 2> next{0, 0};
  while (next[0] < stored[0].size() || next[1] < stored[1].size()) {
    std::uint64_t tick = std::numeric_limits<std::uint64_t>::max();
    for (std::size_t k = 0; k < 2; ++k)
      if (next[k] < stored[k].size()) tick = std::min(tick, stored[k][next[k]].tick);
    double t_s = 0.0;
    for (std::size_t k = 0; k < 2; ++k) {
      if (next[k] < stored[k].size() && stored[k][next[k]].tick == tick) {
        const StoredSample& s = stored[k][next[k]++];
        latest[k] = s.value.raw_position;
        t_s = s.t_s;  // the same loop time for both instruments of one update
      }
    }
    frames.push_back({t_s, latest});
  }
  return frames;
}

}  // namespace hapticlab::db
