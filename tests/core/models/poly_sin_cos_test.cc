// The engine's own sine and cosine (core/models/poly_sin_cos.h) against the
// C library's long double sinl/cosl (64-bit significand: 11 bits more than a
// double, so its error is below 1/1000 of a double's ulp).
#include "core/models/poly_sin_cos.h"

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

namespace hapticlab {
namespace {

std::uint64_t bits_of(double v) { return std::bit_cast<std::uint64_t>(v); }

// |value − exact| in units of the last place of the double nearest `exact`.
double ulps_from(double value, long double exact) {
  const double nearest = static_cast<double>(exact);
  const double ulp = std::nextafter(std::fabs(nearest), std::numeric_limits<double>::infinity()) - std::fabs(nearest);
  return static_cast<double>(std::fabs(static_cast<long double>(value) - exact) / ulp);
}

struct Errors {
  double worst_ulps = 0.0;
  double worst_angle = 0.0;
  int correctly_rounded = 0;
  int count = 0;
  void add(double angle, double value, long double exact) {
    const double e = ulps_from(value, exact);
    if (e > worst_ulps) {
      worst_ulps = e;
      worst_angle = angle;
    }
    if (value == static_cast<double>(exact)) ++correctly_rounded;
    ++count;
  }
};

void check_angle(double x, Errors& sin_errors, Errors& cos_errors) {
  const long double xl = x;
  const SinCos both = poly_sin_cos(x);
  sin_errors.add(x, both.sin, sinl(xl));
  cos_errors.add(x, both.cos, cosl(xl));
  // The single forms are the same computation.
  ASSERT_EQ(bits_of(poly_sin(x)), bits_of(both.sin)) << x;
  ASSERT_EQ(bits_of(poly_cos(x)), bits_of(both.cos)) << x;
}

TEST(PolySinCosTest, WithinOneUlpOfTheExactValueOverTheEnginesAngles) {
  // The engine's angles: pitch and yaw within ±4π, cogging and ripple
  // angles of insertions up to 0.3 m (about ±200 rad), and everything else
  // up to the reduction's limit, uniformly in each band.
  Errors sin_errors, cos_errors;
  std::uint64_t state = 0x9e3779b97f4a7c15ULL;
  auto uniform = [&state] {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(state >> 11) * 0x1p-53;  // [0, 1)
  };
  for (double band : {std::numbers::pi / 4, 4 * std::numbers::pi, 200.0, kPolyMaxAngle_rad}) {
    for (int i = 0; i < 100000; ++i) check_angle((2.0 * uniform() - 1.0) * band, sin_errors, cos_errors);
  }
  EXPECT_LT(sin_errors.worst_ulps, 1.0) << "at " << sin_errors.worst_angle;
  EXPECT_LT(cos_errors.worst_ulps, 1.0) << "at " << cos_errors.worst_angle;
  // Faithful is the promise; in practice almost every result is the
  // correctly rounded one (measured: sine 97.2 %, cosine 96.8 %, whose
  // r²/2 carries z's rounding).
  std::printf("correctly rounded: sine %d of %d, cosine %d of %d\n", sin_errors.correctly_rounded,
              sin_errors.count, cos_errors.correctly_rounded, cos_errors.count);
  EXPECT_GT(sin_errors.correctly_rounded, 0.95 * sin_errors.count);
  EXPECT_GT(cos_errors.correctly_rounded, 0.95 * cos_errors.count);
}

TEST(PolySinCosTest, WithinOneUlpNearTheZerosToo) {
  // The doubles nearest k·π/2, where the sine or cosine almost cancels and
  // the reduction's three-part π/2 (119 bits) is what keeps the result's
  // leading bits.
  Errors sin_errors, cos_errors;
  const long double half_pi = std::numbers::pi_v<long double> / 2;
  for (int k = -100000; k <= 100000; ++k) {
    const double x = static_cast<double>(k * half_pi);
    for (double y : {std::nextafter(x, -1e9), x, std::nextafter(x, 1e9)}) check_angle(y, sin_errors, cos_errors);
  }
  EXPECT_LT(sin_errors.worst_ulps, 1.0) << "at " << sin_errors.worst_angle;
  EXPECT_LT(cos_errors.worst_ulps, 1.0) << "at " << cos_errors.worst_angle;
}

TEST(PolySinCosTest, TheShortcutBelowAQuarterTurnIsTheReductionsOwnResult) {
  // |x| <= π/4 skips the reduction, which would give k = 0, hi = x, lo = 0:
  // the same bits either way, so the shortcut is only a speed-up.
  std::uint64_t state = 7;
  for (int i = 0; i < 100000; ++i) {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    const double x = (static_cast<double>(state >> 11) * 0x1p-53 * 2.0 - 1.0) * (std::numbers::pi / 4);
    const poly_detail::Reduced r = poly_detail::reduce(x);
    ASSERT_EQ(r.quadrant, 0) << x;
    const SinCos reduced = poly_detail::kernels(r.hi, r.lo);
    const SinCos direct = poly_sin_cos(x);
    ASSERT_EQ(bits_of(reduced.sin), bits_of(direct.sin)) << x;
    ASSERT_EQ(bits_of(reduced.cos), bits_of(direct.cos)) << x;
  }
}

TEST(PolySinCosTest, SineIsOddAndCosineEvenToTheBit) {
  // A mirrored motion gives a mirrored force: the reduction rounds half to
  // even, which is symmetric, and the rest is sign-symmetric arithmetic.
  for (double x : {0.1, 0.7853981633974483, 1.0, 2.5, 3.141592653589793, 100.25, 12345.678, 99999.0}) {
    EXPECT_EQ(bits_of(poly_sin(-x)), bits_of(-poly_sin(x))) << x;
    EXPECT_EQ(bits_of(poly_cos(-x)), bits_of(poly_cos(x))) << x;
  }
}

TEST(PolySinCosTest, SignedZerosTinyAnglesAndTheEndsOfTheRange) {
  EXPECT_EQ(bits_of(poly_sin(0.0)), bits_of(0.0));
  EXPECT_EQ(bits_of(poly_sin(-0.0)), bits_of(-0.0));
  EXPECT_EQ(poly_cos(-0.0), 1.0);
  // Below 2^-27 the sine is the angle and the cosine 1, as exactly rounded.
  for (double x : {1e-300, -3e-12, 0x1p-28, std::numeric_limits<double>::denorm_min()}) {
    EXPECT_EQ(poly_sin(x), x);
    EXPECT_EQ(poly_cos(x), 1.0);
    EXPECT_EQ(poly_sin(x), static_cast<double>(sinl(static_cast<long double>(x))));
  }
  // Beyond the reduction's range, and for non-finite angles, the C library.
  for (double x : {2e6, -1e300, std::numeric_limits<double>::infinity()}) {
    EXPECT_EQ(bits_of(poly_sin(x)), bits_of(std::sin(x))) << x;
    EXPECT_EQ(bits_of(poly_cos(x)), bits_of(std::cos(x))) << x;
  }
  EXPECT_TRUE(std::isnan(poly_sin(std::numeric_limits<double>::quiet_NaN())));
  EXPECT_TRUE(std::isnan(poly_sin_cos(-std::numeric_limits<double>::infinity()).cos));
  // Exact values a reader checks by hand.
  EXPECT_EQ(poly_sin(std::numbers::pi / 6), 0.49999999999999994);  // sin of the double nearest π/6
  EXPECT_EQ(poly_cos(std::numbers::pi / 3), static_cast<double>(cosl(static_cast<long double>(std::numbers::pi / 3))));
}

}  // namespace
}  // namespace hapticlab
