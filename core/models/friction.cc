#include "core/models/friction.h"

namespace hapticlab {

void Friction::reset(double position) noexcept {
  sticking_ = true;
  stick_centre_ = position;
  last_force_ = 0.0;
}

}  // namespace hapticlab
