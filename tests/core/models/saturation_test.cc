#include "core/models/saturation.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "testing/chain_driver.h"

namespace hapticlab {
namespace {

TEST(SaturationTest, ClipsSymmetricallyAndZeroRemovesTheForce) {
  EXPECT_EQ(saturate(2.5, 1.0), 1.0);
  EXPECT_EQ(saturate(-2.5, 1.0), -1.0);
  EXPECT_EQ(saturate(0.3, 1.0), 0.3);
  EXPECT_EQ(saturate(-7.0, 0.0), 0.0);  // "No Force Feedback"
}

class SaturationLoopTest : public ::testing::TestWithParam<testing::RateCase> {};

TEST_P(SaturationLoopTest, TheVeForceOnTheAxisNeverExceedsTheLevel) {
  // Per-axis saturation of the VE force (F_ves, Fig. 2-11), 1 N, with a VE
  // force wandering over ±20 N; nothing else on, so the output is F_ves.
  AxisSettings s;
  s.saturation = {true, 1.0};
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(-20.0, 20.0);
  int clipped = 0;
  testing::drive_chain(
      s, GetParam(), 1.0, [](double t) { return 0.1 + 0.01 * std::sin(3 * t); },
      [&](double) { return u(rng); },
      [&](const testing::ChainStep& k) {
        ASSERT_LE(std::abs(k.out.force), 1.0);
        if (std::abs(k.out.force) == 1.0) ++clipped;
      });
  EXPECT_GT(clipped, 0);
}

INSTANTIATE_TEST_SUITE_P(Rates, SaturationLoopTest, ::testing::ValuesIn(testing::kRateCases),
                         [](const auto& info) { return testing::rate_name(info.param); });

}  // namespace
}  // namespace hapticlab
