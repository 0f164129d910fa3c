// The sin/cos memos return exactly std::sin and std::cos, whatever the order
// of the calls (core/models/sin_cos.h).
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

TEST(SinCosTest, MemosGiveTheBitsOfStdSinAndCosInAnyOrderOfCalls) {
  // Repeats, signed zeros (equal values, different sines), a NaN and large
  // angles, asked for as the sine alone or as both, in a fixed pseudo-random
  // order that visits every transition (sine then both, both then sine, ...).
  const std::vector<double> angles = {0.0,  -0.0, 0.3, 0.3, -0.0, 62.83, 1e6,
                                      0.3,  std::numeric_limits<double>::quiet_NaN(), 2.0, 2.0};
  SinCosMemo memo;
  SinMemo sin_memo;
  std::uint64_t state = 12345;
  for (int i = 0; i < 2000; ++i) {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    const double a = angles[(state >> 33) % angles.size()];
    const bool both = ((state >> 20) & 1) != 0;
    const double expected_sin = std::sin(a), expected_cos = std::cos(a);
    if (both) {
      const SinCos sc = memo(a);
      ASSERT_EQ(bits(sc.sin), bits(expected_sin)) << i << " angle " << a;
      ASSERT_EQ(bits(sc.cos), bits(expected_cos)) << i << " angle " << a;
    } else {
      ASSERT_EQ(bits(memo.sin(a)), bits(expected_sin)) << i << " angle " << a;
    }
    ASSERT_EQ(bits(sin_memo(a)), bits(expected_sin)) << i << " angle " << a;
    const SinCos direct = sin_cos(a);
    ASSERT_EQ(bits(direct.sin), bits(expected_sin)) << a;
    ASSERT_EQ(bits(direct.cos), bits(expected_cos)) << a;
  }
}

}  // namespace
}  // namespace hapticlab
