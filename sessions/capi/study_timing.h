#pragma once
// An application's own loop reports each update's tick, time t_s and period
// dt_s; the trial's loop_timing record (the rate a study cites) is made from
// the periods, the analysis from the times. When the two disagree -- a dt_s
// left at 0, given in milliseconds, or measured on a clock that stopped --
// the stored periods do not describe the trial, and the trial must say so.

#include <cstdint>
#include <optional>
#include <string>

#include "core/loop/loop_timing.h"

namespace hapticlab::sessions {

// The samples whose periods `timing` summarises: the first and the last
// one's tick and time.
struct TimedSpan {
  std::uint64_t first_tick = 0, last_tick = 0;
  double first_t_s = 0.0, last_t_s = 0.0;
};

// Disagreements below this fraction are a loop's jitter and clocks' drift
// (the mean period over a whole trial times its updates is its length).
inline constexpr double kTimingMismatchFraction = 0.10;
// Fewer updates than this say too little about a rate to judge it.
inline constexpr std::uint64_t kTimingMinUpdates = 10;

// Why the mean period of `timing` times the updates between the first and
// the last tick is not the time between them (more than
// kTimingMismatchFraction apart), or nullopt when they agree or there is
// too little to tell.
std::optional<std::string> timing_mismatch(const LoopTimingSummary& timing, const TimedSpan& span);

}  // namespace hapticlab::sessions
