#include "core/models/virtual_mass.h"

#include <cmath>

#include <gtest/gtest.h>

namespace hapticlab {
namespace {

TEST(VirtualMassTest, ConstantForceOnFreeMassGivesExactVelocity) {
  // Backward Euler is exact in velocity for a constant force: v = F·t/m.
  VirtualMass m;
  m.reset(0.0, 0.0);
  for (int i = 0; i < 100; ++i) m.step({2.0, 0.0, 0.0}, 0.5, {}, 1e-3);
  EXPECT_NEAR(m.velocity(), 2.0 * 0.1 / 0.5, 1e-12);
}

TEST(VirtualMassTest, KarnoppStickHoldsBelowStaticLimitAndSlidesAbove) {
  const KarnoppFriction k{0.05, 0.04, 0.001};
  VirtualMass m;
  m.reset(0.0, 0.0);
  for (int i = 0; i < 100; ++i) m.step({0.049, 0.0, 0.0}, 0.1, k, 1e-3);
  EXPECT_EQ(m.position(), 0.0);  // eq. 2.13: friction balances 0.049 N
  EXPECT_EQ(m.velocity(), 0.0);
  for (int i = 0; i < 100; ++i) m.step({0.06, 0.0, 0.0}, 0.1, k, 1e-3);
  // eq. 2.14: net 0.06 - 0.04 = 0.02 N on 0.1 kg for 0.1 s -> 0.02 m/s.
  EXPECT_NEAR(m.velocity(), 0.02, 1e-12);
}

TEST(VirtualMassTest, KarnoppFrictionStopsButNeverReversesASlidingMass) {
  const KarnoppFriction k{0.05, 0.04, 0.001};
  VirtualMass m;
  m.reset(0.0, 0.01);  // sliding at 10 mm/s, no other force
  double max_x = 0.0;
  for (int i = 0; i < 1000; ++i) {
    m.step({0.0, 0.0, 0.0}, 0.1, k, 1e-3);
    EXPECT_GE(m.velocity(), 0.0);
    max_x = std::max(max_x, m.position());
  }
  EXPECT_EQ(m.velocity(), 0.0);
  // Stopping distance v²/(2·F/m) = 1e-4/(2·0.4) = 0.125 mm, within one step.
  EXPECT_NEAR(max_x, 0.125e-3, 0.01e-3);
}

TEST(VirtualMassTest, StiffUndampedSpringLosesEnergyAtTheSlowestRate) {
  // K/m = 1e6 s^-2: ω_n·dt = 6.7 at 150 Hz, far beyond the stability limit
  // of explicit schemes. Backward Euler must still not gain energy.
  const double k = 1e5, mass = 0.1, dt = 1.0 / 150;
  VirtualMass m;
  m.reset(0.001, 0.0);
  double energy = 0.5 * k * 0.001 * 0.001;
  for (int i = 0; i < 300; ++i) {
    m.step({-k * m.position(), k, 0.0}, mass, {}, dt);
    const double e = 0.5 * k * m.position() * m.position() + 0.5 * mass * m.velocity() * m.velocity();
    EXPECT_LE(e, energy * (1 + 1e-12));
    energy = e;
  }
}

TEST(VirtualMassTest, CouplingDampingIsTheFractionOfCritical) {
  InertiaParams p{true, 0.1, 600.0, 0.3};
  EXPECT_NEAR(coupling_damping(p), 0.3 * 2 * std::sqrt(600.0 * 0.1), 1e-12);  // 4.648 N·s/m
}

}  // namespace
}  // namespace hapticlab
