#pragma once
// What a study's sessions ran on beyond their settings: the haptic loop's
// rate and, when a simulated participant held the device, the model it was
// drawn from (db session.rate_Hz and participant_model, schema 10). Trials
// of sessions that differ in either are not comparable -- a study resumed
// with another --rate-hz or --population, a pilot's simulated sessions in a
// file of people's -- so a difference is a warning naming the values and
// the sessions, never silent.

#include <cstdint>
#include <string>
#include <vector>

#include "db/study_db.h"

namespace hapticlab::analysis {

struct SessionConditions {
  // "1000 Hz", "not recorded (sessions before HapticLab schema 10)", or
  // "mixed: 1000 Hz (sessions 1, 2); 500 Hz (session 3)".
  std::string rate_text;
  // The model (core/sim/population.h describe_participant_model), "a
  // person at the device", "not recorded ...", or "mixed: ...".
  std::string participant_text;
  std::vector<std::string> warnings;  // one per condition that differs between sessions
};

// Over the sessions of `study_id` in which a trial of the study started.
SessionConditions read_session_conditions(db::StudyDb& db, std::int64_t study_id);

}  // namespace hapticlab::analysis
