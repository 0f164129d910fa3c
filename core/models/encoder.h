#pragma once
// Encoder quantization of a measured position: an ideal incremental encoder
// with `counts_per_unit` counts per m (or rad), its zero at a count centre.

#include <cmath>

namespace hapticlab {

inline double quantize(double position, double counts_per_unit) noexcept {
  return std::round(position * counts_per_unit) / counts_per_unit;
}

}  // namespace hapticlab
