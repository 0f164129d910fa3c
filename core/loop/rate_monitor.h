#pragma once
// RateMonitor: did the haptic loop run at the rate the study asked for?
//
// The update rate is a controlled variable of these studies (the thesis
// manipulates it, Table 3.1), so a trial that ran at another rate measured
// another condition. The loop never bursts to catch up after a late update,
// so time a device call overran is updates lost: a plugin whose write()
// takes 5 ms runs a 1 kHz schedule at 200 Hz, every update a little late
// and none late enough for the lateness watchdog.
//
// Over consecutive windows of at least window_s of loop time, the monitor
// counts the updates that started and adds up the periods the schedule
// asked for between them. The asked rate is updates / asked time (the
// schedule's own rate, also when it wanders), the achieved rate updates /
// elapsed time; a window whose ratio differs from 1 by more than
// tolerance_fraction is a violation. Windows, not a running mean, so a
// rate lost for one second in a long trial is not averaged away.
//
// Wall clock only (the loop asks nothing of it on the virtual clock, where
// time passes exactly as scheduled). update() is real-time safe.

namespace hapticlab {

struct RateCheck {
  static constexpr double kDefaultToleranceFraction = 0.10;
  static constexpr double kDefaultWindow_s = 1.0;
  // |achieved / asked − 1| above this is a violation, 0.001..0.5.
  double tolerance_fraction = kDefaultToleranceFraction;
  // Length of a measuring window [s], 0.05..60.
  double window_s = kDefaultWindow_s;
};

// What a window that broke the tolerance measured.
struct RateViolation {
  double achieved_Hz = 0.0;
  double asked_Hz = 0.0;
  double window_s = 0.0;  // the elapsed time it was measured over
  double tolerance_fraction = 0.0;
};

class RateMonitor {
 public:
  RateMonitor() noexcept = default;
  explicit RateMonitor(const RateCheck& check) noexcept : check_(check) {}

  // The first update starts at now_s: a window opens.
  void start(double now_s) noexcept;
  // An update started at now_s, `asked_period_s` [s] after the one before
  // was due to start by the schedule. Returns true when this closed a window
  // out of tolerance; violation() then holds its figures.
  bool update(double now_s, double asked_period_s) noexcept;
  // The loop is about to end at now_s: the window under way is judged too,
  // if it is at least kMinLastWindow_s long (a shorter one holds too few
  // updates to tell a rate from jitter), so a trial shorter than a window,
  // or its last part, is not left unchecked.
  bool finish(double now_s) noexcept;
  static constexpr double kMinLastWindow_s = 0.25;
  const RateViolation& violation() const noexcept { return violation_; }

 private:
  bool judge(double now_s, double elapsed_s) noexcept;

  RateCheck check_;
  double window_start_s_ = 0.0;
  double asked_s_ = 0.0;
  long updates_ = 0;
  RateViolation violation_;
};

}  // namespace hapticlab
