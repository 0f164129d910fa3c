#include "analysis/metrics/device_energy.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "core/engine/joint_transform.h"

namespace hapticlab::analysis {
namespace {

using Joints = std::array<double, 5>;
using Force3 = std::array<double, 3>;

Joints insertion_at(double x_m) { return {x_m, 0.1, -0.2, 0.0, 0.0}; }

// A constant 2 N push along the insertion while the hand moves in by 1 cm
// and then 2 cm: the device gave 2·0.01 + 2·0.02 = 0.06 J and took nothing.
TEST(DeviceEnergyTest, APushAlongTheMotionGivesForceTimesDistance) {
  EnergyAccumulator acc;
  acc.start();
  for (double x : {0.10, 0.11, 0.13}) acc.add(insertion_at(x), {2.0, 0.0, 0.0}, {0.0, 0.0, 0.0});
  const HandEnergy& e = acc.result();
  EXPECT_EQ(e.intervals, 2u);
  EXPECT_NEAR(e.device[0].out_J, 0.06, 1e-15);
  EXPECT_EQ(e.device[0].in_J, 0.0);
  EXPECT_NEAR(e.engine[0].out_J, 0.06, 1e-15);  // no VE force: all of it is the engine's
  EXPECT_NEAR(e.engine_net_J(), 0.06, 1e-15);
  for (int j : {1, 2}) EXPECT_EQ(e.device[j].out_J + e.device[j].in_J, 0.0);  // the angles did not move
}

// A damper b = 10 N·s/m against a steady 0.1 m/s for 100 updates of 1 ms,
// commanded as the previous interval's velocity: each interval takes
// b·v²·dt = 1e-4 J, 99 intervals after the first command: 9.9e-3 J.
TEST(DeviceEnergyTest, ADamperTakesDampingTimesSpeedSquaredTimesTime) {
  EnergyAccumulator acc;
  acc.start();
  const double b = 10.0, v = 0.1, dt = 1e-3;
  for (int k = 0; k <= 100; ++k) {
    const double force = k == 0 ? 0.0 : -b * v;
    acc.add(insertion_at(0.05 + v * dt * k), {force, 0.0, 0.0}, {0.0, 0.0, 0.0});
  }
  const HandEnergy& e = acc.result();
  EXPECT_EQ(e.intervals, 100u);
  EXPECT_NEAR(e.engine[0].in_J, 99 * b * v * v * dt, 1e-12);
  EXPECT_EQ(e.engine[0].out_J, 0.0);
  EXPECT_LT(e.engine_net_J(), 0.0);
}

// An engine that passes the VE's force through unchanged has no energy of
// its own, whatever the VE does: here a stiff spring on a tool moving in
// all three joints. The device's energy is then all the VE's.
TEST(DeviceEnergyTest, APassThroughEngineHasNoEnergyOfItsOwn) {
  EnergyAccumulator acc;
  acc.start();
  for (int k = 0; k < 50; ++k) {
    const double s = std::sin(0.3 * k);
    const Joints q{0.12 + 0.01 * s, 0.2 * s, -0.1 + 0.05 * s, 0.0, 0.0};
    const Eigen::Vector3d ve(800.0 * 0.01 * s, -3.0 * s, 1.0 + s);  // world frame [N]
    const JointVector command = world_to_joint(JointVector(q[0], q[1], q[2]), ve);
    acc.add(q, {command[0], command[1], command[2]}, {ve[0], ve[1], ve[2]});
  }
  const HandEnergy& e = acc.result();
  double device = 0.0;
  for (int j = 0; j < 3; ++j) {
    EXPECT_NEAR(e.engine[j].out_J, 0.0, 1e-15) << "axis " << j;
    EXPECT_NEAR(e.engine[j].in_J, 0.0, 1e-15) << "axis " << j;
    device += e.device[j].out_J + e.device[j].in_J;
  }
  EXPECT_GT(device, 1e-3);  // the VE did work: the test is not vacuous
}

// A NaN update (a device fault) leaves out the interval into it and the one
// out of it; the rest still count.
TEST(DeviceEnergyTest, AnUpdateThatIsNotANumberLeavesOutItsTwoIntervals) {
  EnergyAccumulator acc;
  acc.start();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  acc.add(insertion_at(0.10), {1.0, 0.0, 0.0}, {0.0, 0.0, 0.0});
  acc.add(insertion_at(0.11), {1.0, 0.0, 0.0}, {0.0, 0.0, 0.0});  // +0.01 J
  acc.add(insertion_at(nan), {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0});
  acc.add(insertion_at(0.20), {1.0, 0.0, 0.0}, {0.0, 0.0, 0.0});
  acc.add(insertion_at(0.22), {1.0, 0.0, 0.0}, {0.0, 0.0, 0.0});  // +0.02 J
  const HandEnergy& e = acc.result();
  EXPECT_EQ(e.intervals, 2u);
  EXPECT_EQ(e.skipped, 2u);
  EXPECT_NEAR(e.device[0].out_J, 0.03, 1e-15);
}

}  // namespace
}  // namespace hapticlab::analysis
