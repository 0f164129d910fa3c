#include "core/models/velocity_filter.h"

#include <cmath>
#include <numbers>

namespace hapticlab {

ButterworthCoefficients butterworth_lowpass_1st(double cutoff_Hz, double dt_s) noexcept {
  const double k = std::tan(std::numbers::pi * cutoff_Hz * dt_s);
  return {k / (1.0 + k), (k - 1.0) / (k + 1.0)};
}

void VelocityFilter::reset(double position, double velocity) noexcept {
  last_position_ = position;
  last_raw_ = velocity;
  filtered_ = velocity;
}

double VelocityFilter::update(double position, double dt_s,
                              const ButterworthCoefficients& c) noexcept {
  if (!(dt_s > 0.0)) {
    // No time passed: a difference quotient is undefined. Keep the estimate
    // and the reference position, so the next update sees the whole motion
    // over the whole time.
    return filtered_;
  }
  const double raw = (position - last_position_) / dt_s;
  filtered_ = c.b * (raw + last_raw_) - c.a1 * filtered_;
  last_raw_ = raw;
  last_position_ = position;
  return filtered_;
}

}  // namespace hapticlab
