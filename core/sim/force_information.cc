#include "core/sim/force_information.h"

#include <algorithm>
#include <cmath>

namespace hapticlab {

double ForceInformation::value() const noexcept {
  if (!(shown_N2_ > 0.0 && ve_N2_ > 0.0)) return 0.0;
  const double v = cross_N2_ / shown_N2_ * (cross_N2_ / ve_N2_);
  return std::isfinite(v) ? std::clamp(v, 0.0, 1.0) : 0.0;
}

}  // namespace hapticlab
