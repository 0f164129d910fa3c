#include "core/loop/rate_monitor.h"

#include <algorithm>
#include <cmath>

namespace hapticlab {

void RateMonitor::start(double now_s) noexcept {
  window_start_s_ = now_s;
  asked_s_ = 0.0;
  updates_ = 0;
}

bool RateMonitor::update(double now_s, double asked_period_s) noexcept {
  ++updates_;
  asked_s_ += asked_period_s;
  const double elapsed_s = now_s - window_start_s_;
  if (elapsed_s < check_.window_s || !(asked_s_ > 0.0)) return false;
  return judge(now_s, elapsed_s);
}

bool RateMonitor::finish(double now_s) noexcept {
  const double elapsed_s = now_s - window_start_s_;
  if (elapsed_s < std::min(kMinLastWindow_s, check_.window_s) || updates_ == 0 || !(asked_s_ > 0.0)) return false;
  return judge(now_s, elapsed_s);
}

bool RateMonitor::judge(double now_s, double elapsed_s) noexcept {
  const double achieved_Hz = static_cast<double>(updates_) / elapsed_s;
  const double asked_Hz = static_cast<double>(updates_) / asked_s_;
  start(now_s);
  if (std::abs(achieved_Hz / asked_Hz - 1.0) <= check_.tolerance_fraction) return false;
  violation_ = {achieved_Hz, asked_Hz, elapsed_s, check_.tolerance_fraction};
  return true;
}

}  // namespace hapticlab
