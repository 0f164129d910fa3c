// ForceGuard: the ramp-in scale, the limit as the smallest of device peak,
// fraction of it and the operator's group limit, and the fail-closed cases.
#include "core/loop/force_guard.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace hapticlab {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(ForceGuardTest, RampIsLinearFromZeroToOne) {
  const ForceGuard guard(workstation_ratings(), {}, 0.4);
  EXPECT_EQ(guard.ramp_scale(-1.0), 0.0);
  EXPECT_EQ(guard.ramp_scale(0.0), 0.0);
  EXPECT_EQ(guard.ramp_scale(0.1), 0.25);
  EXPECT_EQ(guard.ramp_scale(0.2), 0.5);
  EXPECT_EQ(guard.ramp_scale(0.4), 1.0);
  EXPECT_EQ(guard.ramp_scale(100.0), 1.0);
  EXPECT_EQ(guard.ramp_scale(kNaN), 0.0);
  const ForceGuard none(workstation_ratings(), {}, 0.0);
  EXPECT_EQ(none.ramp_scale(0.0), 1.0);
}

TEST(ForceGuardTest, LimitIsTheSmallestOfPeakFractionAndGroupLimit) {
  OperatorForceLimits limits;
  limits.peak_force_fraction = 0.5;
  limits.insertion_force_N = 12.0;  // above half the peak (9.5 N): no effect
  limits.pitch_yaw_torque_Nm = 0.2;  // below half (0.425)
  limits.grip_torque_Nm = 0.0;       // grip force off
  const ForceGuard guard(workstation_ratings(), limits, 0.0);
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(guard.limit(i, kJointInsertion), 9.5);
    EXPECT_EQ(guard.limit(i, kJointPitch), 0.2);
    EXPECT_EQ(guard.limit(i, kJointYaw), 0.2);
    EXPECT_EQ(guard.limit(i, kJointTwist), 0.035);
    EXPECT_EQ(guard.limit(i, kJointGrip), 0.0);
  }
  EXPECT_EQ(guard.limit(2, kJointInsertion), 0.0);
  EXPECT_EQ(guard.limit(0, 5), 0.0);
}

TEST(ForceGuardTest, ApplyScalesThenClampsEveryJointAndCountsTheClamped) {
  const ForceGuard guard(workstation_ratings(), {}, 1.0);
  DeviceCommand c;
  c.force[0] = {40.0, -0.5, 0.5, 0.01, -1.0};
  c.force[1] = {-10.0, kNaN, kInf, 0.0, 0.2};
  // t = 0.5 s: half the force, then the LSW peaks (19 N, 0.85, 0.85, 0.07, 0.32).
  EXPECT_EQ(guard.apply(c, 0.5), 4);  // 20 N, -0.5 N·m grip, NaN, inf
  const DeviceJoints left = {19.0, -0.25, 0.25, 0.005, -0.32};
  const DeviceJoints right = {-5.0, 0.0, 0.0, 0.0, 0.1};
  EXPECT_EQ(c.force[0], left);
  EXPECT_EQ(c.force[1], right);
}

TEST(ForceGuardTest, RatingsThatAreNotNumbersGiveNoForce) {
  DeviceRatings ratings = workstation_ratings();
  ratings.joint[0][kJointInsertion].peak_force = kNaN;
  ratings.joint[1][kJointPitch].peak_force = -1.0;
  ratings.joint[1][kJointYaw].peak_force = kInf;
  const ForceGuard guard(ratings, {}, 0.0);
  EXPECT_EQ(guard.limit(0, kJointInsertion), 0.0);
  EXPECT_EQ(guard.limit(1, kJointPitch), 0.0);
  EXPECT_EQ(guard.limit(1, kJointYaw), 0.0);
  EXPECT_EQ(guard.limit(1, kJointInsertion), 19.0);
  const ForceGuard unset;  // before the loop has the device's ratings
  DeviceCommand c;
  c.force[0][kJointInsertion] = 1.0;
  guard.apply(c, 0.0);
  unset.apply(c, 10.0);
  EXPECT_EQ(c.force[0][kJointInsertion], 0.0);
}

}  // namespace
}  // namespace hapticlab
