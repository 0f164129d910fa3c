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
// events: trial_id,participant,task,setting,repetition,t_s,type,instrument,item_index,detail
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
// Options (ExportSelection): a subset of the channels, every N-th update,
// trials selected by participant, setting or status, one file for the
// whole study, gzip.
//
// Study export adds trials.csv: one row per trial with its plan, status,
// times, abort reason, loop timing, drop counts and the device's own counts
// (device_counters: name=value;..., empty for most devices), and
// operator_actions.csv: the console operator's actions (table
// operator_action; id,session_id,participant,trial_id,unix_s,t_s,type,detail),
// of the selected participants (and, with none selected, those of no
// session).

#include <cstdint>
#include <filesystem>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "db/chunk_reader.h"
#include "db/study_db.h"

namespace hapticlab::db {

// What to export beyond the defaults (everything, a file pair per trial).
struct ExportSelection {
  // Indices into kChannelNames, in the order to write; empty: every channel.
  std::vector<std::size_t> channels;
  // Keep the rows whose tick is a multiple of this (>= 1): both instruments
  // of an update stay together, and the kept times are evenly spaced.
  std::uint64_t every = 1;
  // Trials to export (a whole-study export): empty sets take all.
  std::set<std::string> participants, settings, statuses;
  // One samples.csv and one events.csv for every selected trial (beside
  // trials.csv) instead of a pair per trial.
  bool one_file = false;
  // Write FILE.csv.gz (gzip, zlib) instead of FILE.csv.
  bool gzip = false;
};

// The channel called `name`, or nullopt.
std::optional<std::size_t> channel_index(std::string_view name);

// Returns the files written. Throws DbError (unknown trial, database) or
// std::runtime_error naming the file (cannot write).
std::vector<std::filesystem::path> export_trial_csv(StudyDb& db, std::int64_t trial_id,
                                                    const std::filesystem::path& out_dir,
                                                    std::vector<BadChunk>* bad_chunks = nullptr,
                                                    const ExportSelection& selection = {});

// Every selected trial of the study that has started (planned ones have no
// data), plus trials.csv (the selected trials). Creates out_dir if needed.
std::vector<std::filesystem::path> export_study_csv(StudyDb& db, std::int64_t study_id,
                                                    const std::filesystem::path& out_dir,
                                                    std::vector<BadChunk>* bad_chunks = nullptr,
                                                    const ExportSelection& selection = {});

}  // namespace hapticlab::db
