#include "sessions/capi/study_timing.h"

#include <cmath>
#include <cstdio>

namespace hapticlab::sessions {

std::optional<std::string> timing_mismatch(const LoopTimingSummary& timing, const TimedSpan& span) {
  if (timing.count < kTimingMinUpdates || span.last_tick <= span.first_tick) return std::nullopt;
  const double updates = static_cast<double>(span.last_tick - span.first_tick);
  const double elapsed_s = span.last_t_s - span.first_t_s;
  const double from_periods_s = timing.mean_period_s * updates;
  const double larger = std::max(std::abs(elapsed_s), std::abs(from_periods_s));
  if (!(larger > 0.0) || std::abs(elapsed_s - from_periods_s) <= kTimingMismatchFraction * larger)
    return std::nullopt;
  char text[400];
  std::snprintf(text, sizeof text,
                "the samples' dt_s give a mean period of %.6g ms, but their t_s advance %.6g ms per update "
                "(ticks %llu..%llu over %.6g s): dt_s and t_s disagree (another clock, another unit, or a "
                "clock that stopped), so the stored loop periods do not describe this trial",
                1e3 * timing.mean_period_s, 1e3 * elapsed_s / updates,
                static_cast<unsigned long long>(span.first_tick), static_cast<unsigned long long>(span.last_tick),
                elapsed_s);
  return std::string(text);
}

}  // namespace hapticlab::sessions
