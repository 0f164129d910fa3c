#pragma once
// Force saturation (thesis 2.2.5, Fig. 2-10): the force is clipped to ±level.
// A level of 0 removes the force entirely ("No Force Feedback").

#include <algorithm>

namespace hapticlab {

inline double saturate(double force, double level) noexcept {
  return std::clamp(force, -level, level);
}

}  // namespace hapticlab
