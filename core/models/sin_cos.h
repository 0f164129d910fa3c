#pragma once
// The sine and cosine of one angle, and a one-entry memo of them.
//
// sin/cos are most of an engine update's cost, and an update often asks for
// an angle it asked for last time: a device at rest reads the same counts, a
// virtual mass stuck in its backlash gap stays where it was, an axis without
// backlash shows the VE the measured angle. The memo compares the angle's
// bits (not its value: sin(−0.0) is −0.0, sin(0.0) is 0.0), so a hit
// returns exactly what std::sin and std::cos would return.

#include <math.h>

#include <bit>
#include <cmath>
#include <cstdint>

namespace hapticlab {

struct SinCos {
  double sin = 0.0;
  double cos = 1.0;
};

// std::sin and std::cos of one angle in one call: glibc's sincos(), which
// is what the compiler makes of the pair when it sees both (and gives the
// same bits as the two), but not when one of them is conditional.
inline SinCos sin_cos(double angle) noexcept {
  SinCos r;
  ::sincos(angle, &r.sin, &r.cos);
  return r;
}

class SinCosMemo {
 public:
  SinCos operator()(double angle) noexcept {
    const std::uint64_t bits = std::bit_cast<std::uint64_t>(angle);
    if (bits != sin_bits_) {
      value_ = sin_cos(angle);  // one sincos() call
      sin_bits_ = cos_bits_ = bits;
    } else if (bits != cos_bits_) {
      value_.cos = std::cos(angle);
      cos_bits_ = bits;
    }
    return value_;
  }
  // The sine alone, for a caller that needs no cosine this time (the
  // cosine is computed when it is asked for).
  double sin(double angle) noexcept {
    const std::uint64_t bits = std::bit_cast<std::uint64_t>(angle);
    if (bits != sin_bits_) {
      value_.sin = std::sin(angle);
      sin_bits_ = bits;
    }
    return value_.sin;
  }

 private:
  // The angles whose sine (value_.sin) and cosine (value_.cos) are held;
  // +0.0 at first, whose sine and cosine are exactly 0 and 1.
  std::uint64_t sin_bits_ = 0, cos_bits_ = 0;
  SinCos value_;
};

// The same for the sine alone.
class SinMemo {
 public:
  double operator()(double angle) noexcept {
    const std::uint64_t bits = std::bit_cast<std::uint64_t>(angle);
    if (bits != bits_) {
      value_ = std::sin(angle);
      bits_ = bits;
    }
    return value_;
  }

 private:
  std::uint64_t bits_ = 0;  // +0.0
  double value_ = 0.0;
};

}  // namespace hapticlab
