#pragma once
// Seeds of simulated participants. The participant's traits come from the
// study seed and the participant code; each trial's variation from those
// and its slot in the participant's schedule, so that the same database and
// protocol give the same session, and a session stopped or killed in the
// middle of a trial resumes to the end an uninterrupted one reaches.

#include <cstdint>
#include <string_view>
#include <vector>

#include "db/study_db.h"

namespace hapticlab::sessions {

std::uint64_t participant_seed(std::uint64_t study_seed, std::string_view code) noexcept;
// The variation of the trial of row `trial_id` as first planned.
std::uint64_t trial_seed(std::uint64_t participant_seed, std::int64_t trial_id) noexcept;
// The k-th (0-based) training trial of `task` before the participant's first
// scheduled trial of it in a session.
std::uint64_t training_seed(std::uint64_t participant_seed, std::string_view task, int k) noexcept;
// A staircase trial's (block 0), by its schedule position: its row is added
// as the session goes, so its id depends on every row added before it
// (another participant's staircase, a re-queued trial).
std::uint64_t staircase_trial_seed(std::uint64_t participant_seed, int position) noexcept;

// The seed `trial` runs with, `participant_trials` being all of its
// participant's rows: a designed trial's is trial_seed of the first row of
// its slot (its own id unless it is a re-queued copy, which then runs as
// the interrupted attempt would have), a staircase trial's is
// staircase_trial_seed of its position.
std::uint64_t scheduled_trial_seed(std::uint64_t participant_seed, const db::TrialRow& trial,
                                   const std::vector<db::TrialRow>& participant_trials) noexcept;

}  // namespace hapticlab::sessions
