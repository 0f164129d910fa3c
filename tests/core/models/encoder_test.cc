#include "core/models/encoder.h"

#include <cmath>

#include <gtest/gtest.h>

namespace hapticlab {
namespace {

TEST(EncoderTest, QuantizesToCountsPerUnit) {
  // LSW insertion sensor: 0.008 mm per count = 125000 counts/m (thesis Table 2.1).
  EXPECT_DOUBLE_EQ(quantize(0.0123456, 125000.0), 1543.0 / 125000.0);
  EXPECT_DOUBLE_EQ(quantize(-0.0123456, 125000.0), -1543.0 / 125000.0);
  // 1024 counts per revolution on a rotary axis.
  const double cpr = 1024.0 / (2.0 * M_PI);
  EXPECT_DOUBLE_EQ(quantize(0.01, cpr), 2.0 / cpr);
}

TEST(EncoderTest, ErrorNeverExceedsHalfACount) {
  const double counts = 5000.0;
  for (int i = -1000; i <= 1000; ++i) {
    const double x = i * 1.234567e-5;
    EXPECT_LE(std::abs(quantize(x, counts) - x), 0.5 / counts + 1e-15);
  }
}

}  // namespace
}  // namespace hapticlab
