#pragma once
// A small study database whose every measure can be worked out by hand, for
// the study-analysis, report and `analyze` command tests.
//
// Settings High Fidelity (base force 1 N), No Force Feedback (2 N), Cogging
// (1.5 N); task "dissection". P1 did all three settings twice, P2 the first
// two twice; P1 also has an aborted third Cogging repetition, and P2 a
// planned trial that never ran. Every trial logs 10 samples per hand at
// t_i = i/8 s with events that make the task window [0.25, 0.875] s
// (samples i = 2..7), so the completion time is 0.625 s and, with
// f = base + rep/8 + participant/16 (P1: 1, P2: 2):
//   left  |F| in the window: i = 2 below 1 mN, then f, 2f, 3f, 4f, 5f
//         -> median 3f, MATLAB 95th percentile 5f (position 5.25 > n)
//   right |F| half the left's -> median 1.5f, 95th 2.5f
//   |v| = i/64 -> median (4 + 5)/2/64 = 4.5/64 m/s, both hands
//   path: x = s·i²/1024 with s = 1, 2, 3 by setting -> 45·s/1024 m
// Samples outside the window carry |F| = 100 N so leaking shows. The energy
// (whole trial, device_energy.h): the insertion joint moves 1/64 m an update
// from 0.125 m under a commanded 0.5 N (left) or 0.25 N (right), so the
// device gives 9·0.5/64 = 9/128 J (left) and 9/256 J (right) and takes
// nothing. All values
// are exact in float32, so the database's float storage does not round them.
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "db/study_db.h"
#include "tests/testing/scratch_dir.h"

namespace hapticlab::analysis::testing {

// A scratch folder per test (tests/testing/scratch_dir.h).
struct ScratchDir : hapticlab::testing::ScratchDir {
  ScratchDir() : hapticlab::testing::ScratchDir("hapticlab_an_") {}
};

inline double setting_base_N(int setting) { return setting == 0 ? 1.0 : setting == 1 ? 2.0 : 1.5; }
// f of the header comment; participant 1 or 2, rep 1-based.
inline double trial_force_N(int participant, int setting, int rep) {
  return setting_base_N(setting) + rep / 8.0 + participant / 16.0;
}

// One dissection trial of both hands whose forces in the task window are
// f, 2f, ... 5f (left) and half of that (right), the tip's path scaled by
// `path_scale`: its measures scale with f.
inline void log_trial_of_force(db::StudyDb& db, std::int64_t trial, double f, double path_scale) {
  for (int hand = 0; hand < 2; ++hand) {
    std::vector<db::StoredSample> samples;
    for (int i = 0; i < 10; ++i) {
      db::StoredSample s;
      s.tick = static_cast<std::uint64_t>(i);
      s.t_s = i / 8.0;
      s.dt_s = 1.0 / 8.0;
      const bool inside = i >= 2 && i <= 7;
      const double magnitude = !inside ? 100.0 : i == 2 ? 0.0005 : f * (i - 2) * (hand == 0 ? 1.0 : 0.5);
      s.value.ve_force_N = {0.0, 0.0, magnitude};
      s.value.tip_velocity_m_per_s = {0.0, i / 64.0, 0.0};
      s.value.tip_position_m = {path_scale * i * i / 1024.0, 0.0, 0.0};
      s.value.in_contact = inside && i > 2;
      s.value.raw_position = {0.125 + i / 64.0, 0.0, 0.0, 0.0, 0.0};
      s.value.joint_force = {hand == 0 ? 0.5 : 0.25, 0.0, 0.0};
      samples.push_back(s);
    }
    db.insert_chunk(trial, hand, samples);
  }
  auto event = [&](double t, const char* type, int instrument) {
    db::EventRow e;
    e.trial_id = trial;
    e.t_s = t;
    e.type = type;
    e.instrument = instrument;
    db.add_event(e);
  };
  event(0.0, "contact_start", 0);  // before the tools are in: does not count
  event(0.125, "contact_end", 0);
  event(0.25, "insertion_passed_20mm", 0);
  event(0.375, "contact_start", 1);
  event(0.875, "contact_end", 1);
  event(0.875, "samples_dropped", -1);  // a writer's event: ignored by the window
}

inline void log_trial(db::StudyDb& db, std::int64_t trial, int participant, int setting, int rep) {
  log_trial_of_force(db, trial, trial_force_N(participant, setting, rep), setting + 1);
}

// Builds the database at `path`; returns nothing, the layout is fixed above.
inline void build_synthetic_study(const std::filesystem::path& path) {
  db::StudyDb db(path);
  const std::int64_t study = db.add_study({"synthetic", "{\"study\": \"synthetic\"}", 7, "test"});
  const std::int64_t settings[3] = {db.add_setting_json(study, "High Fidelity", "{}"),
                                    db.add_setting_json(study, "No Force Feedback", "{}"),
                                    db.add_setting_json(study, "Cogging", "{}")};
  for (int participant = 1; participant <= 2; ++participant) {
    const std::int64_t pid = db.add_participant(study, "P" + std::to_string(participant));
    const std::int64_t session = db.begin_session(pid, "sim", "virtual", 1000.0);
    const int n_settings = participant == 1 ? 3 : 2;
    int position = 0;
    // Interleave settings so the trial number is not the setting.
    for (int rep = 1; rep <= 2; ++rep) {
      for (int k = 0; k < n_settings; ++k) {
        const int setting = (k + rep) % n_settings;
        const std::int64_t trial = db.add_trial({pid, "dissection", settings[setting], rep, rep, ++position});
        db.start_trial(trial, session);
        log_trial(db, trial, participant, setting, rep);
        db.end_trial(trial, db::TrialStatus::kComplete);
      }
    }
    if (participant == 1) {
      const std::int64_t trial = db.add_trial({pid, "dissection", settings[2], 3, 3, ++position});
      db.start_trial(trial, session);
      log_trial(db, trial, participant, 2, 3);
      db.end_trial(trial, db::TrialStatus::kAborted, "operator stopped");
    } else {
      db.add_trial({pid, "dissection", settings[0], 3, 3, ++position});  // never run
    }
    db.end_session(session);
  }
}

}  // namespace hapticlab::analysis::testing
