#include "core/engine/loop_emulation.h"

namespace hapticlab {

void SignalDelayHold::reset(const Eigen::Vector3d& value) noexcept {
  now_s_ = 0.0;
  last_hold_s_ = 0.0;
  newest_ = 0;
  cursor_ = 0;
  count_ = 1;
  ring_[0] = {0.0, value};
  held_ = value;
}

Eigen::Vector3d SignalDelayHold::delay_and_hold(const Eigen::Vector3d& value, double latency_s,
                                                double hold_rate_Hz) noexcept {
  Eigen::Vector3d delayed = value;
  if (latency_s > 0.0) {
    // The target time only moves forward, so the cursor does too.
    const double target_s = now_s_ - latency_s;
    for (int n = next(cursor_); cursor_ != newest_ && ring_[n].t_s <= target_s; n = next(cursor_)) {
      cursor_ = n;
    }
    delayed = ring_[cursor_].value;
  } else {
    cursor_ = newest_;
  }

  if (hold_rate_Hz <= 0.0) return held_ = delayed;
  // The reset value counts as the sample at t = 0. The nanosecond slack keeps
  // accumulated dt round-off from slipping a sample by one update.
  const double period_s = 1.0 / hold_rate_Hz;
  if (now_s_ - last_hold_s_ >= period_s - 1e-9) {
    held_ = delayed;
    last_hold_s_ += period_s;
    // After a long gap, restart the sampling grid instead of catching up.
    if (now_s_ - last_hold_s_ >= period_s) last_hold_s_ = now_s_;
  }
  return held_;
}

}  // namespace hapticlab
