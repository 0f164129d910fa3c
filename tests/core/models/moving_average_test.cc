#include "core/models/moving_average.h"

#include <gtest/gtest.h>

namespace hapticlab {
namespace {

TEST(ShortWindowAverageTest, ThreeUpdatesAtHighRates) {
  ShortWindowAverage avg;
  EXPECT_DOUBLE_EQ(avg.add(3.0, 1e-3), 3.0);
  EXPECT_DOUBLE_EQ(avg.add(6.0, 1e-3), 4.5);
  EXPECT_DOUBLE_EQ(avg.add(9.0, 1e-3), 6.0);
  EXPECT_DOUBLE_EQ(avg.add(12.0, 1e-3), 9.0);  // (6+9+12)/3: only the last three
}

TEST(ShortWindowAverageTest, TwentyMillisecondsWinsAtLowRates) {
  ShortWindowAverage avg;
  // At 75 Hz, three updates span 26.7 ms > 20 ms: only two samples are used.
  const double dt = 1.0 / 75.0;
  avg.add(1.0, dt);
  avg.add(2.0, dt);
  EXPECT_DOUBLE_EQ(avg.add(4.0, dt), 3.0);
  // At 150 Hz (the thesis' slowest rate) three updates span 13.3 ms: all used.
  ShortWindowAverage at150;
  at150.add(1.0, 1.0 / 150);
  at150.add(2.0, 1.0 / 150);
  EXPECT_DOUBLE_EQ(at150.add(6.0, 1.0 / 150), 3.0);
}

TEST(ShortWindowAverageTest, ResetForgets) {
  ShortWindowAverage avg;
  avg.add(100.0, 1e-3);
  avg.reset();
  EXPECT_DOUBLE_EQ(avg.add(1.0, 1e-3), 1.0);
}

}  // namespace
}  // namespace hapticlab
