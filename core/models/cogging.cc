#include "core/models/cogging.h"

#include <cmath>
#include <numbers>

namespace hapticlab {

LinearizedForce cogging_force(const CoggingParams& p, double x) noexcept {
  const double wavenumber = 2.0 * std::numbers::pi / p.period;
  const double angle = wavenumber * x + p.phase_rad;
  const double stiffness = p.amplitude * wavenumber * std::cos(angle);
  return {-p.amplitude * std::sin(angle), stiffness > 0.0 ? stiffness : 0.0};
}

double ripple_gain(const CoggingParams& p, double x) noexcept {
  if (p.ripple_fraction == 0.0) return 1.0;
  return 1.0 + p.ripple_fraction * std::sin(2.0 * std::numbers::pi * x / p.ripple_period);
}

}  // namespace hapticlab
