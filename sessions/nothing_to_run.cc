// Whether a session has anything to run before its row is added (nothing_to_run.h).
#include "sessions/nothing_to_run.h"

#include "analysis/study/staircase_progress.h"
#include "sessions/staircase_planner.h"

namespace hapticlab::sessions {

std::optional<std::string> nothing_to_run(StudySession& session, std::optional<int> max_trials,
                                          std::optional<analysis::StaircaseProgress>& staircase) {
  const int planned = session.trials_left();
  // Slots neither complete nor planned: their trials reached the time limit,
  // which is not re-queued.
  const auto counts = [&] {
    return std::to_string(session.complete()) + " complete, " +
           std::to_string(session.scheduled() - session.complete() - planned) + " aborted";
  };
  const std::string none_added = "; no session was added";
  if (max_trials && *max_trials == 0)
    return "participant " + session.participant() + ": no trial run, as at most 0 were asked for (" + counts() +
           ", " + std::to_string(planned) + " still planned)" + none_added;
  if (session.next_trial()) return std::nullopt;
  try {
    staircase = plan_next_staircase_trial(session.db(), session.study(), session.participant_id());
  } catch (const analysis::StaircaseBaselineError&) {
    return std::nullopt;  // the run names it, as for any session
  }
  if (session.next_trial()) return std::nullopt;
  return "participant " + session.participant() + " has no trials left to run: " + counts() +
         " (a trial that reached the time limit is not re-queued)" + none_added;
}

}  // namespace hapticlab::sessions
