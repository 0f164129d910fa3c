// The sin/cos memos return exactly their functions' sines and cosines
// (poly_sin_cos.h for the engine's, std::sin and std::cos for the Libm one),
// whatever the order of the calls (core/models/sin_cos.h).
#include "core/models/sin_cos.h"

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

namespace hapticlab {
namespace {

std::uint64_t bits(double v) { return std::bit_cast<std::uint64_t>(v); }

template <class Trig>
void check_memos_in_any_order() {
  // Repeats, signed zeros (equal values, different sines), a NaN and large
  // angles, asked for as the sine alone or as both, in a fixed pseudo-random
  // order that visits every transition (sine then both, both then sine, ...).
  const std::vector<double> angles = {0.0,  -0.0, 0.3, 0.3, -0.0, 62.83, 1e6,
                                      0.3,  std::numeric_limits<double>::quiet_NaN(), 2.0, 2.0, 3e7};
  BasicSinCosMemo<Trig> memo;
  BasicSinMemo<Trig> sin_memo;
  std::uint64_t state = 12345;
  for (int i = 0; i < 2000; ++i) {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    const double a = angles[(state >> 33) % angles.size()];
    const bool both = ((state >> 20) & 1) != 0;
    const double expected_sin = Trig::sin(a), expected_cos = Trig::cos(a);
    if (both) {
      const SinCos sc = memo(a);
      ASSERT_EQ(bits(sc.sin), bits(expected_sin)) << i << " angle " << a;
      ASSERT_EQ(bits(sc.cos), bits(expected_cos)) << i << " angle " << a;
    } else {
      ASSERT_EQ(bits(memo.sin(a)), bits(expected_sin)) << i << " angle " << a;
    }
    ASSERT_EQ(bits(sin_memo(a)), bits(expected_sin)) << i << " angle " << a;
    const SinCos direct = Trig::sin_cos(a);
    ASSERT_EQ(bits(direct.sin), bits(expected_sin)) << a;
    ASSERT_EQ(bits(direct.cos), bits(expected_cos)) << a;
  }
}

TEST(SinCosTest, TheEnginesMemosGiveTheBitsOfItsSinAndCosInAnyOrderOfCalls) {
  check_memos_in_any_order<PolyTrig>();
  EXPECT_EQ(bits(sin_cos(0.3).sin), bits(poly_sin(0.3)));
}

TEST(SinCosTest, TheLibmMemoGivesTheBitsOfStdSinAndCosInAnyOrderOfCalls) {
  check_memos_in_any_order<LibmTrig>();
  EXPECT_EQ(bits(LibmTrig::sin(0.3)), bits(std::sin(0.3)));
  EXPECT_EQ(bits(LibmTrig::sin_cos(0.3).cos), bits(std::cos(0.3)));
}

}  // namespace
}  // namespace hapticlab
