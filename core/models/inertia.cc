#include "core/models/inertia.h"

namespace hapticlab {

void Inertia::reset(double x_hi, double v_hi) noexcept {
  mass_.reset(x_hi, v_hi);
  average_.reset();
}

}  // namespace hapticlab
