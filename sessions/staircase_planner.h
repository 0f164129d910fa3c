#pragma once
// The next trial of a participant's adaptive staircase (protocols/
// staircase.h, analysis/study/staircase_progress.h): `session run` asks for
// it each time the participant's schedule has nothing planned, so the
// staircase runs after the designed trials, one trial at a time, and a
// session that crashed resumes it from what the database holds.
#include <cstdint>
#include <optional>

#include "analysis/study/staircase_progress.h"
#include "db/study_db.h"

namespace hapticlab::sessions {

// Adds the staircase's next trial as planned (block 0, after the
// participant's last position; its setting stored the first time a strength
// is reached) unless the staircase is finished. Returns the progress it
// planned from; empty when the study has no staircase or the participant
// does not do its task. Throws analysis::StaircaseBaselineError naming staircase.baseline
// when there is no baseline.
std::optional<analysis::StaircaseProgress> plan_next_staircase_trial(db::StudyDb& db, const db::StudyRow& study,
                                                                     std::int64_t participant_id);

}  // namespace hapticlab::sessions
