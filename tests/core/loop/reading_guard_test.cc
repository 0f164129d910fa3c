// ReadingGuard: the widened range, the velocity over a window of at least
// 0.5 ms, and NaN.
#include "core/loop/reading_guard.h"

#include <limits>

#include <gtest/gtest.h>

namespace hapticlab {
namespace {

DeviceReading rest() {
  DeviceReading r;
  for (auto& q : r.position) q = {0.1, 0.0, 0.0, 0.0, 0.1};
  return r;
}

TEST(ReadingGuardTest, RangeIsTheRatingWidenedByTheTolerance) {
  ReadingGuard guard(workstation_ratings(), 0.05);
  DeviceReading r = rest();
  r.position[0][kJointInsertion] = 0.178;  // 0.170 + 8 mm: inside the 8.5 mm margin
  EXPECT_FALSE(guard.check(r, 1e-3).tripped());
  guard.reset();
  r.position[0][kJointInsertion] = 0.179;
  const SafetyTrip trip = guard.check(r, 1e-3);
  EXPECT_EQ(trip.kind, SafetyTripKind::kPositionOutOfRange);
  EXPECT_EQ(trip.instrument, 0);
  EXPECT_EQ(trip.joint, kJointInsertion);
  EXPECT_EQ(trip.value, 0.179);
  EXPECT_NEAR(trip.limit, 0.1785, 1e-15);
  EXPECT_EQ(describe(trip), "left instrument insertion read 0.179 m, outside the allowed -0.0085..0.1785 m");
  r = rest();
  r.position[1][kJointGrip] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(guard.check(r, 1e-3).kind, SafetyTripKind::kPositionOutOfRange);
}

TEST(ReadingGuardTest, VelocityIsMeasuredOverAtLeastHalfAMillisecond) {
  ReadingGuard guard(workstation_ratings(), 0.05);
  DeviceReading r = rest();
  EXPECT_FALSE(guard.check(r, 1e-3).tripped());  // anchors
  // 3.5 mm in 0.1 ms would be 35 m/s, but the window is not complete yet;
  // over the 1 ms that passes by the next reading it is 3.5 m/s (< 4 m/s).
  r.position[0][kJointInsertion] += 0.0035;
  EXPECT_FALSE(guard.check(r, 0.1e-3).tripped());
  EXPECT_FALSE(guard.check(r, 0.9e-3).tripped());
  // 4.5 mm in 1 ms: 4.5 m/s, above the 4 m/s insertion limit.
  r.position[0][kJointInsertion] += 0.0045;
  const SafetyTrip trip = guard.check(r, 1e-3);
  EXPECT_EQ(trip.kind, SafetyTripKind::kVelocityTooHigh);
  EXPECT_EQ(trip.joint, kJointInsertion);
  EXPECT_NEAR(trip.value, 4.5, 1e-9);
  EXPECT_EQ(trip.limit, 4.0);
}

TEST(ReadingGuardTest, ResetForgetsThePreviousReading) {
  ReadingGuard guard(workstation_ratings(), 0.05);
  DeviceReading r = rest();
  EXPECT_FALSE(guard.check(r, 1e-3).tripped());
  guard.reset();
  r.position[1][kJointPitch] = 0.5;  // 0.5 rad since the last reading: 500 rad/s, but a new activation
  EXPECT_FALSE(guard.check(r, 1e-3).tripped());
}

}  // namespace
}  // namespace hapticlab
