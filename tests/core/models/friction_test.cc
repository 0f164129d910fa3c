// Nahvi–Hollerbach friction (thesis eq. 2.10–2.12), checked against numbers
// worked out by hand with the thesis' Table 3.1 translational values:
// μ_d = 0.45 N, d_p = 0.1 mm, hence K_f = μ_d/d_p = 4500 N/m; v_stick = 5 mm/s.
#include "core/models/friction.h"

#include <cmath>
#include <limits>
#include <numbers>

#include <gtest/gtest.h>

#include "core/engine/dof_chain.h"
#include "testing/chain_driver.h"

namespace hapticlab {
namespace {

FrictionParams table31() {
  FrictionParams p;
  p.enabled = true;
  p.dynamic_level = 0.45;
  p.presliding_displacement = 1e-4;
  p.stick_velocity = 0.005;
  return p;
}

TEST(FrictionTest, PreslidingSpringThenBreakawayAtTheDynamicLevel) {
  Friction f;
  f.reset(0.0);
  const FrictionParams p = table31();
  const double v = 0.001;  // slow push, below v_stick
  // Pre-sliding: F = -K_f·x, so -0.225 N at 50 µm and -0.45 N at 100 µm.
  EXPECT_NEAR(f.step(p, 50e-6, v).force, -0.225, 1e-12);
  EXPECT_NEAR(f.step(p, 100e-6, v).force, -0.45, 1e-12);
  EXPECT_TRUE(f.sticking());
  // Beyond d_p the spring breaks away; slow motion drags it and the force
  // stays at μ_d, never above.
  for (double x = 100e-6; x < 2e-3; x += 7e-6) {
    const double force = f.step(p, x, v).force;
    EXPECT_LE(std::abs(force), 0.45 + 1e-12);
    if (x > 110e-6) {
      EXPECT_NEAR(force, -0.45, 1e-12) << x;
    }
  }
}

TEST(FrictionTest, ASubnormalPreslidingRangeGivesFiniteForces) {
  // d_p only has to be > 0, so subnormal doubles (below 2.2e-308) are
  // allowed: here 4 × 4.9e-324 m, so that half of it is exact. K_f =
  // μ_d/d_p = 0.45/2e-323 overflows to infinity, and the stuck contact at
  // rest used to return −K_f·0 = NaN: the engine's "internal fault" with
  // validated settings. Hand-worked: at rest F = 0; half the range
  // stretched F = −μ_d/2 = −0.225 N; at the edge −μ_d; beyond, dragged at −μ_d.
  FrictionParams p = table31();
  p.presliding_displacement = 4 * std::numeric_limits<double>::denorm_min();
  const double dp = p.presliding_displacement;
  Friction f;
  f.reset(0.0);
  const LinearizedForce at_rest = f.step(p, 0.0, 0.0);
  EXPECT_EQ(at_rest.force, 0.0);
  EXPECT_TRUE(std::isfinite(at_rest.stiffness));
  EXPECT_EQ(f.step(p, 0.5 * dp, 0.0).force, -0.225);
  EXPECT_EQ(f.step(p, dp, 0.0).force, -0.45);
  EXPECT_EQ(f.step(p, 1e-6, 0.001).force, -0.45);  // dragged at μ_d
  EXPECT_TRUE(f.sticking());
}

TEST(FrictionTest, SlipForceOpposesVelocityAtTheDynamicLevel) {
  Friction f;
  f.reset(0.0);
  const FrictionParams p = table31();
  f.step(p, 0.0, 0.05);
  EXPECT_NEAR(f.step(p, 0.2e-3, 0.05).force, -0.45, 1e-12);  // breakaway, fast
  EXPECT_FALSE(f.sticking());
  EXPECT_NEAR(f.step(p, 0.5e-3, 0.05).force, -0.45, 1e-12);
  EXPECT_NEAR(f.step(p, 0.4e-3, -0.05).force, +0.45, 1e-12);
}

TEST(FrictionTest, SlipToStickIsContinuousAndReversalRampsOverTwicePresliding) {
  Friction f;
  f.reset(0.0);
  const FrictionParams p = table31();
  f.step(p, 1e-3, 0.05);
  f.step(p, 2e-3, 0.05);  // slipping forward: F = -0.45
  // Slows below v_stick at x = 3 mm: eq. 2.12 puts the centre at 3 mm - d_p,
  // so the force is still -0.45 N (continuous).
  EXPECT_NEAR(f.step(p, 3e-3, 0.001).force, -0.45, 1e-12);
  EXPECT_TRUE(f.sticking());
  EXPECT_NEAR(f.stick_centre(), 3e-3 - 1e-4, 1e-15);
  // Moving back: F = -K_f·(x - x_c) goes linearly from -0.45 through 0 (at
  // the centre) to +0.45 N, 2·d_p = 0.2 mm back from the turning point.
  EXPECT_NEAR(f.step(p, 3e-3 - 0.5e-4, -0.001).force, -0.225, 1e-12);
  EXPECT_NEAR(f.step(p, 3e-3 - 1.0e-4, -0.001).force, 0.0, 1e-12);
  EXPECT_NEAR(f.step(p, 3e-3 - 2.0e-4, -0.001).force, 0.45, 1e-12);
}

// Through the full DOF chain (filtered velocity, measured dt) at every rate.
class FrictionLoopTest : public ::testing::TestWithParam<testing::RateCase> {};

TEST_P(FrictionLoopTest, HysteresisLoopDissipatesTheParallelogramArea) {
  // x = A·sin(2π f t). Force against position is a parallelogram: ±μ_d
  // during slip, linear over 2·d_p after each reversal. Its area, the energy
  // dissipated per cycle, is 2·μ_d·(2A − 2·d_p) = 4·μ_d·(A − d_p).
  const double amplitude_m = 5e-3, freq_Hz = 1.0;
  AxisSettings s;
  s.friction = table31();
  double x_prev = 0.0, work_on_hand_J = 0.0, peak_N = 0.0;
  testing::drive_chain(
      s, GetParam(), 3.0,
      [&](double t) { return amplitude_m * std::sin(2 * std::numbers::pi * freq_Hz * t); },
      testing::no_force(), [&](const testing::ChainStep& k) {
        if (k.t_s > 1.0 && k.t_s <= 3.0) work_on_hand_J += k.out.force * (k.x - x_prev);  // 2 cycles
        peak_N = std::max(peak_N, std::abs(k.out.force));
        x_prev = k.x;
      });
  const double expected_J = 2 * 4 * 0.45 * (amplitude_m - 1e-4);  // 2 cycles: 0.01764 J
  // Tolerance 2%: the rectangle-rule sum misplaces each force switch by up to
  // one step; at 150 Hz a step is 0.2 mm ≈ 2% of the 2A = 10 mm travel in
  // the worst case at mid-stroke, much less near the turning points where
  // the switches happen.
  EXPECT_NEAR(-work_on_hand_J, expected_J, 0.02 * expected_J);
  EXPECT_LE(peak_N, 0.45 + 1e-12);
}

TEST_P(FrictionLoopTest, RotationalVariantUsesTheSameModelInItsUnits) {
  // Table 3.1 rotation: 30 mN·m, 0.01 rad pre-sliding; Table 2.2: 0.1 rad/s.
  AxisSettings s;
  s.friction = {true, 0.030, 0.01, 0.1};
  double last_torque_Nm = 0.0;
  testing::drive_chain(  // rotate at 0.5 rad/s for half a second
      s, GetParam(), 0.5, [](double t) { return 0.5 * t; }, testing::no_force(),
      [&](const testing::ChainStep& k) { last_torque_Nm = k.out.force; });
  EXPECT_NEAR(last_torque_Nm, -0.030, 1e-12);
}

INSTANTIATE_TEST_SUITE_P(Rates, FrictionLoopTest, ::testing::ValuesIn(testing::kRateCases),
                         [](const auto& info) { return testing::rate_name(info.param); });

}  // namespace
}  // namespace hapticlab
