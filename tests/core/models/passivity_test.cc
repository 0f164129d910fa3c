// The passivity observer and controller (core/models/passivity.h) against
// numbers worked by hand.
#include "core/models/passivity.h"

#include <cmath>

#include <gtest/gtest.h>

namespace hapticlab {
namespace {

PassivityParams params(double window_s = 0.1, double min_velocity = 1e-3, double max_damping = 100.0) {
  return {true, window_s, min_velocity, max_damping};
}

// A damper F = −b·v takes energy in every update (e = b·v²·dt > 0): the
// controller never acts and the force passes unchanged, bit for bit.
TEST(PassivityTest, APassiveDamperIsLeftAlone) {
  PassivityController pc;
  const PassivityParams p = params();
  for (int k = 0; k < 1000; ++k) {
    const double v = 0.05 * std::sin(0.01 * k);
    const double f = -2.0 * v;
    EXPECT_EQ(pc.step(p, f, v, 0.001), f) << k;
  }
  EXPECT_EQ(pc.dissipated(), 0.0);
}

// An active element F = +b·v at constant v: the first update would give out
// b·v²·dt; the controller adds exactly α = b, so F' = 0 and the window
// stays at 0. b = 3 N·s/m, v = 0.1 m/s, dt = 1 ms: e = −3e-5 J per update.
TEST(PassivityTest, AnActiveElementIsDampedToPassiveWorkedByHand) {
  PassivityController pc;
  const PassivityParams p = params();
  for (int k = 0; k < 50; ++k) {
    EXPECT_NEAR(pc.step(p, 3.0 * 0.1, 0.1, 0.001), 0.0, 1e-15) << k;
    EXPECT_NEAR(pc.last_damping(), 3.0, 1e-12);
    EXPECT_NEAR(pc.window_energy(), 0.0, 1e-18);
  }
  EXPECT_NEAR(pc.dissipated(), 50 * 3e-5, 1e-15);
}

// The cap: α at most max_damping = 1 N·s/m, so F' = 0.3 − 1·0.1 = 0.2 N
// and the window keeps going negative, by −0.2·0.1·0.001 = −2e-5 J a step.
TEST(PassivityTest, TheDampingIsCapped) {
  PassivityController pc;
  const PassivityParams p = params(0.1, 1e-3, 1.0);
  EXPECT_NEAR(pc.step(p, 0.3, 0.1, 0.001), 0.2, 1e-15);
  EXPECT_NEAR(pc.step(p, 0.3, 0.1, 0.001), 0.2, 1e-15);
  EXPECT_NEAR(pc.window_energy(), -4e-5, 1e-18);
}

// Below the velocity floor nothing is computed; the debt stays in the
// window and is taken when the device moves: after 10 slow updates giving
// out 0.3·5e-4·1e-3 = 1.5e-7 J each, the first fast update (v = 0.1) owes
// 1.5e-6 J plus its own 3e-5 J: α = 3.15e-5 / (0.01·0.001) = 3.15.
TEST(PassivityTest, BelowTheVelocityFloorTheDebtWaits) {
  PassivityController pc;
  const PassivityParams p = params(0.1, 1e-3, 100.0);
  for (int k = 0; k < 10; ++k) EXPECT_EQ(pc.step(p, 0.3, 5e-4, 0.001), 0.3);
  EXPECT_NEAR(pc.window_energy(), -1.5e-6, 1e-18);
  pc.step(p, 0.3, 0.1, 0.001);
  EXPECT_NEAR(pc.last_damping(), 3.15, 1e-9);
  EXPECT_NEAR(pc.window_energy(), 0.0, 1e-18);
}

// The window forgets: 1 s of a damper (F = −1 N at 0.1 m/s, 1e-4 J an
// update) stores 0.1 J, which a plain sum lets an active element (3e-5 J
// given out an update) spend for over 3000 updates. With a 0.05 s window
// an update is judged with the M entries that fit before it (M + 1 entries
// of 1 ms within 0.05 s: M = 49, or 48 when the summed dt rounds above):
// at active update k that is (M − k)·1e-4 − (k + 1)·3e-5 J, negative from
// k = 38 (M = 49) or 37 (M = 48).
int first_damped_update(double window_s) {
  PassivityController pc;
  const PassivityParams p = params(window_s);
  for (int k = 0; k < 1000; ++k) pc.step(p, -1.0, 0.1, 0.001);
  for (int k = 0; k < 200; ++k) {
    pc.step(p, 3.0 * 0.1, 0.1, 0.001);
    if (pc.last_damping() > 0.0) return k;
  }
  return -1;
}

TEST(PassivityTest, AnOldStoreOfDissipationCannotHideANewInstability) {
  const int k = first_damped_update(0.05);
  EXPECT_TRUE(k == 37 || k == 38) << k;
  EXPECT_EQ(first_damped_update(kMaxPassivityWindow_s), -1);  // the 2 s window still holds the store
}

TEST(PassivityTest, ANonPositiveDtChangesNothing) {
  PassivityController pc;
  EXPECT_EQ(pc.step(params(), 0.3, 0.1, 0.0), 0.3);
  EXPECT_EQ(pc.step(params(), 0.3, 0.1, -1.0), 0.3);
  EXPECT_EQ(pc.window_energy(), 0.0);
}

}  // namespace
}  // namespace hapticlab
