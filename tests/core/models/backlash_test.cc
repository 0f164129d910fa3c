// Backlash (thesis 2.2.2, eq. 2.7–2.8, 2.13–2.14).
#include "core/models/backlash.h"

#include <cmath>

#include <gtest/gtest.h>

#include "core/engine/dof_chain.h"
#include "testing/chain_driver.h"

namespace hapticlab {
namespace {

AxisSettings inertia_backlash() {
  AxisSettings s;
  s.inertia = {true, 0.1, 600.0, 0.3};                // Table 3.1 / 2.2
  s.backlash = {true, 0.002, 0.05, 0.04, 0.001};      // 2 mm gap
  return s;
}

class BacklashLoopTest : public ::testing::TestWithParam<testing::RateCase> {};

TEST_P(BacklashLoopTest, ZeroForceDeadBandEqualsTheGap) {
  // Sweep slowly (2 mm/s) forward 3 mm, then back 6 mm. On the way back the
  // instrument crosses the gap with exactly zero force: from leaving the
  // front wall to touching the back wall it travels one gap width (2 mm),
  // plus the contact spring's decompression at the front wall (the mass was
  // pushed against Karnopp friction of at most 0.05 N: 0.05/600 = 0.083 mm),
  // minus the few steps the 3-update average needs to reach exactly zero.
  const AxisSettings s = inertia_backlash();
  const double v = 0.002, turn_s = 1.5;  // 3 mm forward, then back to -3 mm
  double zero_start = NAN, zero_end = NAN;
  testing::drive_chain(
      s, GetParam(), 3 * turn_s,
      [&](double t) { return t < turn_s ? v * t : v * (2 * turn_s - t); }, testing::no_force(),
      [&](const testing::ChainStep& k) {
        ASSERT_LE(std::abs(k.out.position - k.x), 0.001 + 1e-12);  // VE sees at most gap/2
        if (k.t_s < turn_s) return;
        if (k.out.force == 0.0 && std::isnan(zero_start)) zero_start = k.x;
        if (k.out.force != 0.0 && !std::isnan(zero_start) && std::isnan(zero_end)) zero_end = k.x;
      });
  ASSERT_FALSE(std::isnan(zero_start));
  ASSERT_FALSE(std::isnan(zero_end));
  const double band = zero_start - zero_end;
  const double step = v * kMaxDt_s;  // the longest step any rate case takes
  EXPECT_GT(band, 0.002 - 3 * step);
  EXPECT_LT(band, 0.002 + 0.05 / 600 + 3 * step);
}

TEST_P(BacklashLoopTest, VeForceReachesTheHandOnlyThroughTheWall) {
  // A steady 0.5 N VE force pushes the mass forward against the front wall;
  // with the instrument held still the user feels the full 0.5 N (minus the
  // Karnopp friction the mass may keep) through the compressed coupling.
  DofOutput out;
  testing::drive_chain(inertia_backlash(), GetParam(), 1.5, [](double) { return 0.0; },
                       testing::constant_force(0.5),
                       [&](const testing::ChainStep& k) { out = k.out; });
  EXPECT_NEAR(out.force, 0.5, 0.05 + 1e-6);
  // The VE sees the tool at the wall, gap/2 ahead (infinitely stiff walls).
  EXPECT_NEAR(out.position, 0.001, 1e-12);
}

INSTANTIATE_TEST_SUITE_P(Rates, BacklashLoopTest, ::testing::ValuesIn(testing::kRateCases),
                         [](const auto& info) { return testing::rate_name(info.param); });

}  // namespace
}  // namespace hapticlab
