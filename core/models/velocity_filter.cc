#include "core/models/velocity_filter.h"

#include <numbers>

#include "core/models/sin_cos.h"

namespace hapticlab {

ButterworthCoefficients butterworth_lowpass_1st(double cutoff_Hz, double dt_s) noexcept {
  // With k = tan(π·fc·dt) = s/c: k/(1 + k) = s/(c + s) and
  // (k − 1)/(k + 1) = (s − c)/(s + c), one division for both (the engine's
  // sine and cosine, not libm's tan: issue 36 §1).
  const SinCos w = sin_cos(std::numbers::pi * cutoff_Hz * dt_s);
  const double inverse_sum = 1.0 / (w.sin + w.cos);
  return {w.sin * inverse_sum, (w.sin - w.cos) * inverse_sum};
}

void VelocityFilter::reset(double position, double velocity) noexcept {
  last_position_ = position;
  last_raw_ = velocity;
  filtered_ = velocity;
}

}  // namespace hapticlab
