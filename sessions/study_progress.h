#pragma once
// What `hapticlab study show` prints: the stored schedule and each
// participant's progress through it (operator view: names the settings).

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "analysis/study/session_conditions.h"
#include "db/study_db.h"

namespace hapticlab::sessions {

// Where a participant of a between-group design stands
// (protocols/sittings.h): the group, the next sitting and when it is due.
struct SittingProgress {
  std::string group;
  int sittings_done = 0;
  int sittings = 0;
  std::string next_phase;       // "pre_test", ..., or "done"
  int next_session = 0;         // 1-based within next_phase; 0 when done
  std::optional<double> due_unix_s;  // nullopt: due now (or done)
};

struct ParticipantProgress {
  std::string code;
  int planned = 0;     // still to run (re-queued trials included)
  int running = 0;     // a trial in progress (another process is running it)
  int complete = 0;
  int aborted = 0;     // kept, marked, left out of analysis by default
  int scheduled = 0;   // trials in the original schedule
  std::vector<db::TrialRow> trials;  // schedule order
  // Only for a protocol with groups; old studies print as before.
  std::optional<SittingProgress> sitting;
};

struct StudyProgress {
  db::StudyRow study;
  std::vector<ParticipantProgress> participants;
  // The loop rate and who held the device over the sessions that ran a
  // trial, with a warning for each that differs (analysis/study/session_conditions.h).
  analysis::SessionConditions conditions;
};

// Reads the (single) study of the database. Throws std::runtime_error if
// the file holds no study.
StudyProgress study_progress(db::StudyDb& db);

std::string format_study_progress(const StudyProgress& progress, bool with_schedule);
nlohmann::json study_progress_json(const StudyProgress& progress);

}  // namespace hapticlab::sessions
