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

}  // namespace hapticlab
