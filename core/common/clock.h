#pragma once
// The haptic loop's time source.
//
// WallClock is real time (std::chrono::steady_clock) for sessions with a
// person at the device. VirtualClock only moves when the loop tells it to, so
// the same loop runs as fast as the CPU allows and a seed fully determines
// the result: for demos, tests and study planning.

#include <chrono>

namespace hapticlab {

class Clock {
 public:
  virtual ~Clock() = default;
  // Seconds since the clock was created (or reset).
  virtual double now_s() const noexcept = 0;
  // Returns when now_s() >= t_s. Real-time safe: no allocation or locks.
  virtual void sleep_until(double t_s) noexcept = 0;
  virtual bool is_virtual() const noexcept = 0;
};

class VirtualClock final : public Clock {
 public:
  double now_s() const noexcept override { return now_s_; }
  // Jumps to t_s (never backwards).
  void sleep_until(double t_s) noexcept override {
    if (t_s > now_s_) now_s_ = t_s;
  }
  bool is_virtual() const noexcept override { return true; }

 private:
  double now_s_ = 0.0;
};

class WallClock final : public Clock {
 public:
  WallClock() noexcept : start_(std::chrono::steady_clock::now()) {}
  double now_s() const noexcept override {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  // Sleeps with the OS until shortly before t_s, then spins: an OS wake-up
  // alone is late by 50–100 µs on a loaded machine, more than the loop's
  // jitter budget.
  void sleep_until(double t_s) noexcept override;
  bool is_virtual() const noexcept override { return false; }

  // How long before the deadline the OS sleep ends and spinning starts [s].
  static constexpr double kSpinMargin_s = 150e-6;

 private:
  std::chrono::steady_clock::time_point start_;
};

}  // namespace hapticlab
