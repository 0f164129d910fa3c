#include "core/loop/stall_probe.h"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace hapticlab {

void StallCounter::add(double t_s) noexcept {
  const auto window = static_cast<std::int64_t>(std::floor(t_s / kWindow_s));
  if (!started_) {
    started_ = true;
    last_s_ = t_s;
    window_ = window;
    return;
  }
  if (window != window_) {
    // Windows passed over whole by a long stall are not counted: they were
    // not sampled, and the stall already counts in the window where it ends.
    ++result_.windows;
    if (window_stalled_) ++result_.windows_with_stall;
    window_ = window;
    window_stalled_ = false;
  }
  const double gap_s = t_s - last_s_;
  if (gap_s > threshold_s_) window_stalled_ = true;
  result_.max_stall_s = std::max(result_.max_stall_s, gap_s);
  last_s_ = t_s;
}

StallProbeResult probe_stalls(double duration_s, double threshold_s) {
  using Clock = std::chrono::steady_clock;
  StallCounter counter(threshold_s);
  const Clock::time_point start = Clock::now();
  for (;;) {
    const double t_s = std::chrono::duration<double>(Clock::now() - start).count();
    counter.add(t_s);
    if (t_s >= duration_s) break;
  }
  return counter.result();
}

}  // namespace hapticlab
