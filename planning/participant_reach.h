#pragma once
// Whether the participant-level comparison (analysis/study/participant_level.h)
// can find anything at all with a number of participants: its sign-flip
// test's smallest p is 2/2^n, so below some n no data can bring it under
// the Šidák level, and the power plan power prints there (0 %) is 0 by
// construction, not a finding about the settings.
#include <cstddef>
#include <string>

namespace hapticlab::planning {

// Empty when the test can reach the Šidák level of `comparisons`
// comparisons at `alpha` with `participants` participants; otherwise the
// note that says why the power is 0, with the smallest p, the level and
// the participants it needs (or that no number of them can reach it).
std::string participant_power_note(int participants, double alpha, std::size_t comparisons);

}  // namespace hapticlab::planning
