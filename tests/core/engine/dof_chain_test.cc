// Combined settings on one DOF (thesis 2.2.6.1, Fig. 2-11 / 2-12).
#include "core/engine/dof_chain.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "core/models/cogging.h"
#include "testing/chain_driver.h"

namespace hapticlab {
namespace {

AxisSettings all_degradations() {
  AxisSettings s;
  s.friction = {true, 0.45, 1e-4, 0.005};
  s.cogging = {true, 0.45, 0.010, 0.0, 0.0, 0.010};
  s.saturation = {true, 1.0};
  s.inertia = {true, 0.1, 600.0, 0.3};
  s.backlash = {true, 0.002, 0.05, 0.04, 0.001};
  return s;
}

class DofChainLoopTest : public ::testing::TestWithParam<testing::RateCase> {};

TEST_P(DofChainLoopTest, WithoutBacklashTheForcesAddOnTheInstrument) {
  // Fig. 2-12: F = F_ves + cogging(x) + friction(x, v) + inertia. At a
  // constant velocity of 50 mm/s (slip, no acceleration) and a 3 N VE force
  // clipped to 1 N: F = 1 − 0.45 + cogging(x) ± small inertia noise.
  AxisSettings s = all_degradations();
  s.backlash.enabled = false;
  const double tolerance_N = GetParam().jittered() ? 3e-3 : 1e-5;
  testing::drive_chain(
      s, GetParam(), 1.0, [](double t) { return 0.05 * t; }, testing::constant_force(3.0),
      [&](const testing::ChainStep& k) {
        // The start from rest excites the coupling (ζ = 0.3, ω_n = 77 rad/s),
        // which decays as exp(−ζ·ω_n·t): below 1e-6 N after 0.6 s.
        if (k.t_s <= 0.6) return;
        const double expected = 1.0 - 0.45 + cogging_force(s.cogging, k.x).force;
        ASSERT_NEAR(k.out.force, expected, tolerance_N) << k.t_s;
        ASSERT_EQ(k.out.position, k.x);
      });
}

TEST_P(DofChainLoopTest, WithBacklashTheForcesActOnTheMassAndTheVeSeesTheGap) {
  // Fig. 2-11. Holding the instrument still against a steady 0.8 N VE force
  // (under the 1 N clip): the mass settles pressed against the wall, the
  // user feels the VE force plus the cogging at the limited position, less
  // what friction (up to 0.45 N + Karnopp 0.05 N) holds back.
  const AxisSettings s = all_degradations();
  DofOutput out;
  double max_offset = 0.0;
  testing::drive_chain(s, GetParam(), 2.0, [](double) { return 0.0; },
                       testing::constant_force(0.8), [&](const testing::ChainStep& k) {
                         out = k.out;
                         max_offset = std::max(max_offset, std::abs(k.out.position));
                       });
  EXPECT_LE(max_offset, 0.001 + 1e-12);
  const double wall_cogging = cogging_force(s.cogging, out.position).force;
  EXPECT_LE(out.force, 0.8 + wall_cogging + 1e-3);
  EXPECT_GE(out.force, 0.8 + wall_cogging - 0.45 - 0.05 - 1e-3);
}

TEST_P(DofChainLoopTest, AllDegradationsStayBoundedAndPassiveOnAHandMotion) {
  // A wandering hand motion for 5 s, back to its start and at rest at the
  // end: the net work the chain does on the hand must not be positive (the
  // models are passive: friction dissipates, cogging is conservative, the
  // implicitly integrated mass stores and returns energy without gain).
  AxisSettings s = all_degradations();
  s.friction.enabled = true;
  double x_prev = 0.0, work_on_hand_J = 0.0, peak = 0.0;
  testing::drive_chain(
      s, GetParam(), 6.0,
      [](double t) {
        return t < 5.0 ? 0.01 * std::sin(1.3 * t) * std::sin(2 * std::numbers::pi * t / 5.0) : 0.0;
      },
      testing::no_force(), [&](const testing::ChainStep& k) {
        work_on_hand_J += k.out.force * (k.x - x_prev);
        peak = std::max(peak, std::abs(k.out.force));
        x_prev = k.x;
      });
  EXPECT_LE(work_on_hand_J, 1e-5);
  EXPECT_LT(peak, 2.0);
}

INSTANTIATE_TEST_SUITE_P(Rates, DofChainLoopTest, ::testing::ValuesIn(testing::kRateCases),
                         [](const auto& info) { return testing::rate_name(info.param); });

TEST(DofChainTest, SwitchingInertiaOnWhileMovingStartsWithoutAForceJump) {
  AxisSettings off;
  AxisSettings on;
  on.inertia = {true, 0.1, 600.0, 0.3};
  DofChain chain;
  chain.reset(off, 0.0);
  double x = 0.0;
  const double dt = 1e-3;
  for (int i = 0; i < 200; ++i) {
    x += 0.1 * dt;
    chain.step(off, x, 0.0, dt, butterworth_lowpass_1st(70.0, dt));
  }
  chain.on_settings_change(off, on);
  x += 0.1 * dt;
  const DofOutput out = chain.step(on, x, 0.0, dt, butterworth_lowpass_1st(70.0, dt));
  // The mass starts at the instrument with its velocity: no stretched spring.
  EXPECT_NEAR(out.force, 0.0, 1e-9);
}

TEST(DofChainTest, ShrinkingTheGapKeepsTheMassInsideIt) {
  AxisSettings wide = all_degradations();
  AxisSettings narrow = wide;
  narrow.backlash.gap = 0.0005;
  DofChain chain;
  chain.reset(wide, 0.0);
  const double dt = 1e-3;
  for (int i = 0; i < 100; ++i) chain.step(wide, 0.0, 0.5, dt, butterworth_lowpass_1st(70.0, dt));
  chain.on_settings_change(wide, narrow);
  const DofOutput out = chain.step(narrow, 0.0, 0.5, dt, butterworth_lowpass_1st(70.0, dt));
  EXPECT_LE(std::abs(out.position), 0.00025 + 1e-12);
  EXPECT_LE(std::abs(out.force), 0.5 + 0.45 + 0.05);
}

}  // namespace
}  // namespace hapticlab
