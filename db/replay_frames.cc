#include "db/replay_frames.h"

#include <algorithm>
#include <array>
#include <limits>
#include <span>
#include <string>

#include "db/chunk_reader.h"

namespace hapticlab::db {

namespace {

[[noreturn]] void refuse_damage(const StudyDb& db, std::int64_t trial_id, const std::vector<BadChunk>& bad) {
  std::string list;
  for (const BadChunk& c : bad) list += "; " + describe(c);
  throw DbError(db.path() + ": trial " + std::to_string(trial_id) + " cannot be replayed: " +
                std::to_string(bad.size()) + " damaged sample chunk(s)" + list);
}

}  // namespace

std::vector<ReplayFrame> load_replay_frames(StudyDb& db, std::int64_t trial_id) {
  db.trial(trial_id);  // throws, naming the trial, if there is none
  TrialChunks chunks(db.connection(), trial_id);
  // Misplaced chunks are known before any blob is read.
  if (!chunks.bad().empty()) refuse_damage(db, trial_id, chunks.bad());
  if (chunks.updates(0) == 0 && chunks.updates(1) == 0)
    throw DbError(db.path() + ": trial " + std::to_string(trial_id) +
                  " has no stored samples, so there is nothing to replay (has it run?)");

  // The two instruments' chunks streamed and merged: one frame per tick, a
  // window of each in memory besides the frames.
  std::vector<ReplayFrame> frames;
  frames.reserve(std::max(chunks.updates(0), chunks.updates(1)));
  std::array<std::span<const StoredSample>, 2> window;
  std::array<std::size_t, 2> pos{0, 0};
  std::array<DeviceJoints, 2> latest{};
  std::array<bool, 2> seen{false, false};
  for (;;) {
    for (std::size_t k = 0; k < 2; ++k)
      if (pos[k] == window[k].size()) {
        window[k] = chunks.next(static_cast<int>(k));
        pos[k] = 0;
      }
    std::uint64_t tick = std::numeric_limits<std::uint64_t>::max();
    for (std::size_t k = 0; k < 2; ++k)
      if (!window[k].empty()) tick = std::min(tick, window[k][pos[k]].tick);
    if (window[0].empty() && window[1].empty()) break;
    double t_s = 0.0;
    for (std::size_t k = 0; k < 2; ++k) {
      if (window[k].empty() || window[k][pos[k]].tick != tick) continue;
      const StoredSample& s = window[k][pos[k]++];
      if (!seen[k]) {
        // Before its first stored update an instrument holds its first
        // stored position: fill in the frames made without it.
        for (ReplayFrame& f : frames) f.position[k] = s.value.raw_position;
        seen[k] = true;
      }
      latest[k] = s.value.raw_position;
      t_s = s.t_s;  // the same loop time for both instruments of one update
    }
    frames.push_back({t_s, latest});
  }
  if (!chunks.bad().empty()) refuse_damage(db, trial_id, chunks.bad());
  return frames;
}

}  // namespace hapticlab::db
