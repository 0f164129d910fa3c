#pragma once
// ControlGrid: something slower than the haptic loop — a participant's
// control, a cue's sampling, slow noise — acting on a fixed grid of
// instants every period_s from t = 0, at the first loop update at or after
// each grid point. On the grid, a loop whose period divides period_s acts
// exactly every period_s; a slower loop acts at every update and the grid
// restarts from there.
//
// Loop times are sums of dt, so an update meant to land on a grid point can
// fall a rounding error short of it; kTimeSlack_s absorbs that (the loop's
// shortest update is 500 µs).

namespace hapticlab {

inline constexpr double kTimeSlack_s = 1e-6;

class ControlGrid {
 public:
  explicit constexpr ControlGrid(double period_s) noexcept : period_s_(period_s) {}

  // True at the first update [s] at or after the next grid point.
  constexpr bool due(double t_s) const noexcept { return t_s >= next_s_ - kTimeSlack_s; }
  // After acting at t_s: on to the next grid point, or to t_s + period_s if
  // the caller came later than that (a loop slower than the grid).
  constexpr void advance(double t_s) noexcept {
    next_s_ += period_s_;
    if (next_s_ <= t_s + kTimeSlack_s) next_s_ = t_s + period_s_;
  }
  constexpr double period_s() const noexcept { return period_s_; }

 private:
  double period_s_;
  double next_s_ = 0.0;
};

}  // namespace hapticlab
