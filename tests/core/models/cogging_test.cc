#include "core/models/cogging.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "core/engine/dof_chain.h"
#include "testing/chain_driver.h"

namespace hapticlab {
namespace {

CoggingParams cogging_table31() {
  CoggingParams p;
  p.enabled = true;
  p.amplitude = 0.45;  // N, thesis Table 3.1
  p.period = 0.010;    // m, our documented default
  p.ripple_period = 0.010;
  return p;
}

TEST(CoggingTest, AmplitudePeriodAndStableDetentAtZero) {
  const CoggingParams p = cogging_table31();
  double peak = 0.0;
  for (int i = 0; i <= 20000; ++i) {
    const double x = i * 1e-6;  // 0..20 mm, two periods
    peak = std::max(peak, std::abs(cogging_force(p, x).force));
  }
  EXPECT_NEAR(peak, 0.45, 1e-9);
  // Peaks at a quarter period, zero at half periods, period 10 mm.
  EXPECT_NEAR(cogging_force(p, 0.0025).force, -0.45, 1e-12);
  EXPECT_NEAR(cogging_force(p, 0.0075).force, +0.45, 1e-12);
  EXPECT_NEAR(cogging_force(p, 0.005).force, 0.0, 1e-12);
  for (double x : {0.0013, 0.0042, -0.0031}) {
    EXPECT_NEAR(cogging_force(p, x).force, cogging_force(p, x + 0.010).force, 1e-12);
  }
  // x = 0 is a stable detent: pushed right, the force pulls back left.
  EXPECT_LT(cogging_force(p, 1e-4).force, 0.0);
  EXPECT_GT(cogging_force(p, -1e-4).force, 0.0);
  // Its restoring stiffness there is A·2π/p = 282.7 N/m.
  EXPECT_NEAR(cogging_force(p, 0.0).stiffness, 0.45 * 2 * std::numbers::pi / 0.010, 1e-9);
  EXPECT_EQ(cogging_force(p, 0.005).stiffness, 0.0);  // unstable detent: none
}

TEST(CoggingTest, RippleScalesTheCommandedForce) {
  CoggingParams p = cogging_table31();
  p.ripple_fraction = 0.1;
  p.ripple_period = 0.004;
  EXPECT_NEAR(ripple_gain(p, 0.001), 1.1, 1e-12);  // quarter ripple period
  EXPECT_NEAR(ripple_gain(p, 0.003), 0.9, 1e-12);
  p.ripple_fraction = 0.0;
  EXPECT_EQ(ripple_gain(p, 0.001), 1.0);
}

class CoggingLoopTest : public ::testing::TestWithParam<testing::RateCase> {};

TEST_P(CoggingLoopTest, ChainOutputIsThePositionFunctionAtAnyRate) {
  AxisSettings s;
  s.cogging = cogging_table31();
  testing::drive_chain(
      s, GetParam(), 1.0, [](double t) { return 0.03 * std::sin(2.0 * t); }, testing::no_force(),
      [](const testing::ChainStep& k) {
        ASSERT_NEAR(k.out.force, -0.45 * std::sin(2 * std::numbers::pi * k.x / 0.010), 1e-12);
      });
}

TEST_P(CoggingLoopTest, RippleModulatesVeForceAndCogging) {
  AxisSettings s;
  s.cogging = cogging_table31();
  s.cogging.ripple_fraction = 0.05;
  testing::drive_chain(
      s, GetParam(), 0.5, [](double t) { return 0.02 * t; }, testing::constant_force(2.0),
      [](const testing::ChainStep& k) {
        const double phase = 2 * std::numbers::pi * k.x / 0.010;
        ASSERT_NEAR(k.out.force, (2.0 - 0.45 * std::sin(phase)) * (1.0 + 0.05 * std::sin(phase)),
                    1e-12);
      });
}

INSTANTIATE_TEST_SUITE_P(Rates, CoggingLoopTest, ::testing::ValuesIn(testing::kRateCases),
                         [](const auto& info) { return testing::rate_name(info.param); });

}  // namespace
}  // namespace hapticlab
