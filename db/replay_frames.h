#pragma once
// Replay from the study database: a stored trial's raw device positions as
// ReplayDevice frames (core/device/replay_device.h), so a recorded motion
// can be re-run through another degradation setting or a changed VE.
//
// One frame per stored update (tick), at the update's loop time t_s, with
// both instruments' raw joints (insertion m, pitch, yaw, twist, grip rad)
// as read from the device. The two instruments are logged together, so
// normally every tick has both; if one instrument lacks a tick (a damaged
// or hand-edited file), it holds its previous position there, and before
// its first stored update its first stored position, as the CSV loader
// does. Ticks missing from both (a "samples_missing" gap) are simply
// absent: the replay holds the last frame until the next one is due.
//
// Precision: the positions are exactly what the database holds, which is
// the device reading rounded to the nearest float32 (db/sample_codec.h): at
// most 2^-24 relative, 6 nm on a 0.1 m insertion and 0.2 µrad on 3 rad,
// far below any encoder of thesis Table 2.1. t_s is exact (float64).

#include <cstdint>
#include <vector>

#include "core/device/replay_device.h"
#include "db/study_db.h"

namespace hapticlab::db {

// Throws DbError naming the file and trial if the trial does not exist,
// has no stored samples (a planned trial: nothing to replay) or has a
// damaged sample chunk (chunk_reader.h), each named with its instrument and
// ticks. A damaged chunk is refused rather than left out: the replay would
// hold that instrument still over the hole, a motion nobody made.
std::vector<ReplayFrame> load_replay_frames(StudyDb& db, std::int64_t trial_id);

}  // namespace hapticlab::db
