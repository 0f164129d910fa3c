#include "core/models/backlash.h"

namespace hapticlab {

void Backlash::reset(double x_hi, double v_hi) noexcept {
  mass_.reset(x_hi, v_hi);
  average_.reset();
}

void Backlash::confine(double x_hi, double gap) noexcept {
  mass_.set_position(limited_position(x_hi, gap));
}

}  // namespace hapticlab
