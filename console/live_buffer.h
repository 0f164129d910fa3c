#pragma once
// The console's copy of the last seconds of a running loop for its live
// plots: one point per instrument every 1/rate_Hz of loop time, taken from
// samples someone else already drains (the sample writer, a free trial's
// sink), never on the haptic loop's thread. Not thread-safe: its owner
// guards it.

#include <array>
#include <deque>
#include <span>
#include <vector>

#include "core/loop/loop_sample.h"

namespace hapticlab::console {

// One point of the live plots: an instrument's state at one update.
struct LivePoint {
  double t_s = 0.0;                // loop time
  float tip_force_N = 0.0f;        // |VE force at the tip|
  float displayed_force_N = 0.0f;  // |force displayed to the hand|
  float insertion_m = 0.0f, pitch_rad = 0.0f, yaw_rad = 0.0f;
};

class LiveBuffer {
 public:
  // rate_Hz > 0: points kept per instrument and second; window_s: how far back.
  LiveBuffer(double rate_Hz, double window_s) : step_s_(1.0 / rate_Hz), window_s_(window_s) {}

  void clear();  // a new trial: its loop time starts again at 0
  void add(std::span<const LoopSample> batch);
  // Points of each instrument with loop time > after_t_s.
  std::array<std::vector<LivePoint>, 2> since(double after_t_s) const;
  double newest_t_s() const { return newest_t_s_; }  // the newest sample seen (0 after clear)

 private:
  double step_s_, window_s_;
  std::array<std::deque<LivePoint>, 2> points_;
  std::array<double, 2> next_t_s_{0.0, 0.0};
  double newest_t_s_ = 0.0;
};

}  // namespace hapticlab::console
