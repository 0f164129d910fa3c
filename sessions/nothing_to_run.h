#pragma once
// Before a session row is added: is anything left for this session to run?
// A participant whose schedule (and staircase) is done, or a run asked for
// at most 0 trials, would otherwise get an empty session in the study
// every time the command is run again.
#include <optional>
#include <string>

#include "analysis/study/staircase_progress.h"
#include "sessions/study_session.h"

namespace hapticlab::sessions {

// Why `session` (opened, not begun) has nothing to run, for the operator:
// its trials complete and aborted for good (and planned, under
// max_trials 0); empty when there is a trial to run. A staircase protocol
// whose schedule is done plans its next trial here, as the run would;
// `staircase` gets the progress it planned from. A staircase without a
// baseline is left for the run to name.
std::optional<std::string> nothing_to_run(StudySession& session, std::optional<int> max_trials,
                                          std::optional<analysis::StaircaseProgress>& staircase);

}  // namespace hapticlab::sessions
