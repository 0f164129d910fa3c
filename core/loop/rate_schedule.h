#pragma once
// RateSchedule: the sequence of update periods a virtual environment (VE)
// asks of the haptic loop — either a fixed rate, or the rate the thesis'
// VE actually ran at, which wandered between 200 and 2000 Hz out of the
// experimenters' control (thesis 2.1.4).
//
// The wandering model, per update of period dt:
//
//   y = ln(rate [Hz]), μ = (ln min_Hz + ln max_Hz)/2, half-width w = (ln max_Hz − ln min_Hz)/2
//   y ← μ + (y − μ)·e^(−dt/τ) + σ·sqrt(1 − e^(−2·dt/τ))·N(0,1), reflected at ln min_Hz, ln max_Hz
//   period = e^(−y)·e^(σ_j·N(0,1)), clamped to [1/max_Hz, 1/min_Hz]
//
// an Ornstein–Uhlenbeck walk in log-rate, exact for any dt: the rate drifts
// over about τ = kWanderTimeConstant_s (0.5 s: slow enough for a participant
// to feel stretches of smooth and of coarse updates, as the thesis' scene
// load did), with stationary spread σ = w/2, so it visits the whole range
// within a few seconds, reverting to the geometric mean of the bounds (632 Hz
// for 200..2000 Hz). σ_j = kWanderJitterLogSd (2 %) is the per-update jitter
// of a busy scheduler on top. All randomness is core/common/random.h, so a
// seed gives the same schedule everywhere.
//
// Not thread-safe: one schedule per loop.

#include <cstdint>

#include "core/common/random.h"

namespace hapticlab {

class RateSchedule {
 public:
  // The range the haptic loop supports [Hz] (the engine's dt policy, README).
  static constexpr double kMinRate_Hz = 150.0;
  static constexpr double kMaxRate_Hz = 2000.0;
  static constexpr double kWanderTimeConstant_s = 0.5;
  static constexpr double kWanderJitterLogSd = 0.02;

  // rate_Hz in [150, 2000], else std::invalid_argument naming the value and range.
  static RateSchedule fixed(double rate_Hz);
  // 150 <= min_Hz <= max_Hz <= 2000, else std::invalid_argument. Starts at a
  // rate drawn from the walk's stationary distribution.
  static RateSchedule thesis_wander(std::uint64_t seed, double min_Hz = 200.0,
                                    double max_Hz = 2000.0);

  // The period before the next VE update [s], in [1/max_Hz, 1/min_Hz].
  double next_period_s() noexcept;
  // Fixed: 1/rate. Wander: the period at the centre rate, 1/sqrt(min_Hz·max_Hz).
  double nominal_period_s() const noexcept;

  bool is_fixed() const noexcept { return !wander_; }
  double min_rate_Hz() const noexcept { return min_Hz_; }
  double max_rate_Hz() const noexcept { return max_Hz_; }

 private:
  RateSchedule(bool wander, double min_Hz, double max_Hz, std::uint64_t seed) noexcept;
  double reflect_into_range(double log_rate) const noexcept;

  bool wander_;
  double min_Hz_;
  double max_Hz_;
  double min_log_;     // ln min_Hz
  double max_log_;     // ln max_Hz
  double centre_log_;  // μ
  double sigma_log_;   // σ, stationary sd of ln rate
  double log_rate_;    // y, current state
  Random rng_;
};

}  // namespace hapticlab
