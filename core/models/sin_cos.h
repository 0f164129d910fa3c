#pragma once
// The sine and cosine of one angle, and one-entry memos of them.
//
// The engine and the models take their trigonometry from poly_sin_cos.h
// (its own polynomials: fast, and the same bits on every machine). The
// analysis recomputes poses from stored angles with the C library's sin
// and cos, which its numpy comparator (bench/analyze_numpy.py) reproduces to
// the bit with Python's math.sin and math.cos: it uses the Libm memo.
//
// An update often asks for an angle it asked for last time: a device at
// rest reads the same counts, a virtual mass stuck in its backlash gap stays
// where it was, an axis without backlash shows the VE the measured angle.
// A memo compares the angle's bits (not its value: sin(−0.0) is −0.0,
// sin(0.0) is 0.0), so a hit returns exactly what its functions return.

#include <math.h>

#include <bit>
#include <cmath>
#include <cstdint>

#include "core/models/poly_sin_cos.h"

namespace hapticlab {

// The engine's sine and cosine of one angle (poly_sin_cos.h).
inline SinCos sin_cos(double angle) noexcept { return poly_sin_cos(angle); }

// The trigonometry a memo calls.
struct PolyTrig {
  static SinCos sin_cos(double a) noexcept { return poly_sin_cos(a); }
  static double sin(double a) noexcept { return poly_sin(a); }
  static double cos(double a) noexcept { return poly_cos(a); }
};
struct LibmTrig {
  // glibc's sincos(): the same bits as std::sin and std::cos in one call.
  static SinCos sin_cos(double a) noexcept {
    SinCos r;
    ::sincos(a, &r.sin, &r.cos);
    return r;
  }
  static double sin(double a) noexcept { return std::sin(a); }
  static double cos(double a) noexcept { return std::cos(a); }
};

template <class Trig>
class BasicSinCosMemo {
 public:
  SinCos operator()(double angle) noexcept {
    const std::uint64_t bits = std::bit_cast<std::uint64_t>(angle);
    if (bits != sin_bits_) {
      value_ = Trig::sin_cos(angle);
      sin_bits_ = cos_bits_ = bits;
    } else if (bits != cos_bits_) {
      value_.cos = Trig::cos(angle);
      cos_bits_ = bits;
    }
    return value_;
  }
  // The sine alone, for a caller that needs no cosine this time (the
  // cosine is computed when it is asked for).
  double sin(double angle) noexcept {
    const std::uint64_t bits = std::bit_cast<std::uint64_t>(angle);
    if (bits != sin_bits_) {
      value_.sin = Trig::sin(angle);
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
template <class Trig>
class BasicSinMemo {
 public:
  double operator()(double angle) noexcept {
    const std::uint64_t bits = std::bit_cast<std::uint64_t>(angle);
    if (bits != bits_) {
      value_ = Trig::sin(angle);
      bits_ = bits;
    }
    return value_;
  }

 private:
  std::uint64_t bits_ = 0;  // +0.0
  double value_ = 0.0;
};

using SinCosMemo = BasicSinCosMemo<PolyTrig>;
using SinMemo = BasicSinMemo<PolyTrig>;
using LibmSinCosMemo = BasicSinCosMemo<LibmTrig>;

}  // namespace hapticlab
