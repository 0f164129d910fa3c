#pragma once
// The engine's sine and cosine: a Cody–Waite reduction by π/2 and Taylor
// polynomials on |r| <= π/4, written here rather than taken from the C
// library, for two reasons (issue 36 §1):
//
//  - Speed. glibc's sin, cos and sincos switch the SSE rounding mode on
//    entry and back on exit (two MXCSR writes) and branch on the argument's
//    range; with tan they were a third of an engine update. These are
//    straight-line code except for two well-predicted range checks.
//  - The same bits everywhere. glibc picks an implementation by CPU
//    feature (its FMA and non-FMA variants may differ in the last bit) and
//    by version; these use only IEEE additions and multiplications,
//    so a simulated study gives the same numbers on every x86-64
//    and ARM machine with -ffp-contract=off (CMakeLists.txt sets it: GCC
//    contracts C++ into FMAs by default where the target has them).
//
// Accuracy (tests/core/models/poly_sin_cos_test.cc, against long double):
// within 1 ulp of the exact value for |x| <= kPolyMaxAngle_rad, the doubles
// nearest multiples of π/2 included, and the correctly rounded value for
// about 97 % of sines and cosines. Beyond that range, and for a
// non-finite angle, the C library is called (an engine angle there would be
// a fault).
//
// Derivation: x = k·π/2 + r with k the nearest integer to x·2/π; π/2 is
// split into three parts P1 + P2 + P3 (at most 33, 33 and 53 significant bits,
// computed from π to 80 digits), so k·P1 and k·P2 are exact products for
// |k| < 2^20 and x − k·P1 is exact (Sterbenz); the rounding of
// (x − k·P1) − k·P2 is kept by an exact two-sum and, less k·P3, forms lo
// (r = hi + lo, not renormalized: |lo| may exceed an ulp of hi). On
// |r| <= π/4 the Taylor series of sin to r^17 and of cos to r^16 leave
// truncation errors below 1e-19 and 3e-18 of the result. sin(hi + lo) =
// sin(hi) + lo·cos(hi) and cos(hi + lo) = cos(hi) − lo·sin(hi) to first order
// (|lo| < 2e-16 in range, so the next terms are below 1e-31).

#include <math.h>

#include <cmath>
#include <cstdint>

namespace hapticlab {

struct SinCos {
  double sin = 0.0;
  double cos = 1.0;
};

// Largest |angle| [rad] reduced here. The exact products need k < 2^20
// (|x| < 1.6e6), but near multiples of π/2 beyond about 8e5 rad the rounding
// of k·P3 can cost just over an ulp; up to 1e5 every double nearest a
// multiple of π/2 is checked (the engine's angles stay within ±200 rad).
inline constexpr double kPolyMaxAngle_rad = 1.0e5;

namespace poly_detail {

inline constexpr double kTwoOverPi = 0x1.45f306dc9c883p-1;
inline constexpr double kPio2Part1 = 0x1.921fb544p+0;           // 31 significant bits
inline constexpr double kPio2Part2 = 0x1.0b4611a6p-34;          // 32 significant bits
inline constexpr double kPio2Part3 = 0x1.3198a2e037073p-69;     // the rest
inline constexpr double kRoundShifter = 0x1.8p52;               // x + 1.5·2^52 rounds x to an integer
// Below this |x|, sin x = x and cos x = 1 to the last bit (x²/2 < 2^-55,
// under half an ulp below 1).
inline constexpr double kTinyAngle_rad = 0x1p-27;

// The Taylor series' sums for z = r² (z2 = z², z4 = z⁴), by Estrin's
// scheme, whose chain of dependent operations is half Horner's:
// sin r = r + r·z·sin_tail, cos r = 1 − z/2 + z²·cos_tail.
inline double sin_tail(double z, double z2, double z4) noexcept {
  return ((-1.0 / 6.0 + z * (1.0 / 120.0)) + z2 * (-1.0 / 5040.0 + z * (1.0 / 362880.0))) +
         z4 * ((-1.0 / 39916800.0 + z * (1.0 / 6227020800.0)) +
               z2 * (-1.0 / 1307674368000.0 + z * (1.0 / 355687428096000.0)));
}
inline double cos_tail(double z, double z2, double z4) noexcept {
  return ((1.0 / 24.0 + z * (-1.0 / 720.0)) + z2 * (1.0 / 40320.0 + z * (-1.0 / 3628800.0))) +
         z4 * ((1.0 / 479001600.0 + z * (-1.0 / 87178291200.0)) + z2 * (1.0 / 20922789888000.0));
}

struct Reduced {
  double hi;
  double lo;
  std::int64_t quadrant;  // k mod 4 in the two's complement's low bits
};

// a + b − sum exactly, for sum = a + b rounded (Knuth's two-sum).
inline double two_sum_error(double a, double b, double sum) noexcept {
  const double a_part = sum - b;
  const double b_part = sum - a_part;
  return (a - a_part) + (b - b_part);
}

// x = k·π/2 + hi + lo, |hi| <= π/4 (plus rounding), |lo| < 2e-16;
// |x| <= kPolyMaxAngle_rad. For |x| <= π/4, k = 0, hi = x and lo = 0,
// which the caller may take without calling this (the same bits).
inline Reduced reduce(double x) noexcept {
  const double k = (x * kTwoOverPi + kRoundShifter) - kRoundShifter;
  const double t = x - k * kPio2Part1;  // exact
  const double w = k * kPio2Part2;      // exact
  const double hi = t - w;
  return {hi, two_sum_error(t, -w, hi) - k * kPio2Part3, static_cast<std::int64_t>(k)};
}

// sin and cos of hi + lo, |hi| <= π/4. lo (the two-sum's error less
// k·P3) enters to first order with the other function's value:
// sin(hi + lo) = sin hi + lo·cos hi, cos(hi + lo) = cos hi − lo·sin hi
// (the next terms are below 1e-30).
inline SinCos kernels(double hi, double lo) noexcept {
  const double z = hi * hi;
  const double z2 = z * z;
  const double z4 = z2 * z2;
  const double sin_rest = (hi * z) * sin_tail(z, z2, z4);
  const double cos_rest = z2 * cos_tail(z, z2, z4);
  // 1 − z/2 with its rounding error carried (it is most of the cosine).
  const double half_z = 0.5 * z;
  const double one_minus = 1.0 - half_z;
  const double cos_hi = one_minus + cos_rest;
  const double sin_hi = hi + sin_rest;
  return {hi + (sin_rest + lo * cos_hi), one_minus + (((1.0 - one_minus) - half_z) + (cos_rest - lo * sin_hi))};
}

// The reduced kernels of x, and x's quadrant; |x| <= kPolyMaxAngle_rad.
inline SinCos reduced_kernels(double x, double magnitude, std::int64_t& quadrant) noexcept {
  constexpr double kQuarterPi = 0x1.921fb54442d18p-1;  // the double below π/4
  if (magnitude <= kQuarterPi) {
    quadrant = 0;
    return kernels(x, 0.0);
  }
  const Reduced r = reduce(x);
  quadrant = r.quadrant;
  return kernels(r.hi, r.lo);
}

}  // namespace poly_detail

inline SinCos poly_sin_cos(double x) noexcept {
  using namespace poly_detail;
  const double magnitude = std::fabs(x);
  if (magnitude < kTinyAngle_rad) return {x, 1.0};  // keeps sin(−0) = −0
  if (!(magnitude <= kPolyMaxAngle_rad)) {
    SinCos r;
    ::sincos(x, &r.sin, &r.cos);
    return r;
  }
  std::int64_t quadrant;
  const SinCos k = reduced_kernels(x, magnitude, quadrant);
  // sin(qπ/2 + r) and cos(qπ/2 + r) by quadrant q.
  const bool odd = (quadrant & 1) != 0;
  const double sin_sign = (quadrant & 2) != 0 ? -1.0 : 1.0;
  const double cos_sign = ((quadrant + 1) & 2) != 0 ? -1.0 : 1.0;
  return {sin_sign * (odd ? k.cos : k.sin), cos_sign * (odd ? k.sin : k.cos)};
}

inline double poly_sin(double x) noexcept { return poly_sin_cos(x).sin; }
inline double poly_cos(double x) noexcept { return poly_sin_cos(x).cos; }

}  // namespace hapticlab
