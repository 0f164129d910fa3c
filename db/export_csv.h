#pragma once
// CSV export of stored trials, for other tools (R, Python, a spreadsheet).
//
// Per trial, two files in `out_dir`, named
//   <participant>_<task>_<setting>_rep<r>_trial<id>_samples.csv
//   <participant>_<task>_<setting>_rep<r>_trial<id>_events.csv
// (names reduced to [a-z0-9_-]: "All Degradations" -> all_degradations).
//
// samples: one row per update per instrument, in tick order, left before right:
//   trial_id,participant,task,setting,repetition,instrument,tick,
//   then the channels of sample_codec.h (kChannelNames) in that order:
//   dt_s,t_s, raw_* (5), degraded_* (3), tip_{x,y,z}_m, tip_v{x,y,z}_m_per_s,
//   ve_force_{x,y,z}_N, displayed_force_{x,y,z}_N, insertion_force_N,
//   pitch_torque_Nm, yaw_torque_Nm, engine_status, device_status, in_contact
// events: trial_id,participant,task,setting,repetition,t_s,type,instrument,index,detail
//
// Numbers are the shortest text that reads back to the stored value:
// float64 channels (t_s, dt_s) exactly as doubles; float32 channels exactly
// when read as float32 (read as double they give the short decimal, within
// the codec's 2^-24 relative precision, e.g. "0.0001"). Text fields are quoted when they need it (RFC 4180).
// Each file is written to "<name>.tmp" and renamed when complete.
//
// A damaged sample chunk (chunk_reader.h) is left out of the samples file
// and appended to `bad_chunks`; the rest of the trial is exported. Without
// a list to report them to (null), a damaged chunk throws DbError naming
// them, so nothing is left out silently.
//
// Study export adds trials.csv: one row per trial with its plan, status,
// times, abort reason, loop timing, drop counts and the device's own counts
// (device_counters: name=value;..., empty for most devices).

#include <cstdint>
#include <filesystem>
#include <vector>

#include "db/chunk_reader.h"
#include "db/study_db.h"

namespace hapticlab::db {

// Returns the files written. Throws DbError (unknown trial, database) or
// std::runtime_error naming the file (cannot write).
std::vector<std::filesystem::path> export_trial_csv(StudyDb& db, std::int64_t trial_id,
                                                    const std::filesystem::path& out_dir,
                                                    std::vector<BadChunk>* bad_chunks = nullptr);

// Every trial of the study that has started (planned ones have no data),
// plus trials.csv. Creates out_dir if needed.
std::vector<std::filesystem::path> export_study_csv(StudyDb& db, std::int64_t study_id,
                                                    const std::filesystem::path& out_dir,
                                                    std::vector<BadChunk>* bad_chunks = nullptr);

}  // namespace hapticlab::db
