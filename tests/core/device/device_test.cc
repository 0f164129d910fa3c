#include "core/device/device.h"

#include <set>
#include <string>

#include <gtest/gtest.h>

#include "core/device/workstation_spec.h"

namespace hapticlab {
namespace {

TEST(DeviceStatusTest, EveryStatusHasItsOwnStableName) {
  EXPECT_STREQ(to_string(DeviceStatus::kOk), "ok");
  EXPECT_STREQ(to_string(DeviceStatus::kReadFailed), "read_failed");
  EXPECT_STREQ(to_string(DeviceStatus::kNonFiniteReading), "non_finite_reading");
  EXPECT_STREQ(to_string(DeviceStatus::kEndOfData), "end_of_data");
  EXPECT_STREQ(to_string(DeviceStatus::kTimeout), "device_timeout");  // the trial's abort reason
  std::set<std::string> names;
  const int last = kNumDeviceStatuses - 1;
  for (int s = 0; s <= last; ++s) names.insert(to_string(static_cast<DeviceStatus>(s)));
  EXPECT_EQ(names.size(), static_cast<std::size_t>(last + 1));
  EXPECT_EQ(names.count("unknown"), 0u);
  EXPECT_STREQ(to_string(static_cast<DeviceStatus>(last + 1)), "unknown");
}

TEST(WorkstationSpecTest, RatingsAreTableTwoPointOneForBothInstruments) {
  const DeviceRatings ratings = workstation_ratings();
  for (const auto& instrument : ratings.joint) {
    for (int j = 0; j < kNumDeviceJoints; ++j) {
      const DeviceJointRating& r = instrument[static_cast<std::size_t>(j)];
      const WorkstationJointSpec& spec = kWorkstationJoints[static_cast<std::size_t>(j)];
      EXPECT_EQ(r.min_position, spec.min_position);
      EXPECT_EQ(r.max_position, spec.max_position);
      EXPECT_EQ(r.continuous_force, spec.continuous_force);
      EXPECT_EQ(r.peak_force, spec.peak_force);
      EXPECT_GT(r.max_velocity, 0.0);
    }
    EXPECT_EQ(instrument[kJointInsertion].peak_force, 19.0);
  }
}

TEST(WorkstationSpecTest, TableTwoPointOneInSiUnits) {
  // Spans: 170 mm, 100°, 100°, 180°, 20°.
  const double spans[] = {0.170, 100.0, 100.0, 180.0, 20.0};
  const double resolutions[] = {0.008e-3, 0.01, 0.01, 0.03, 0.04};
  for (int j = 0; j < kNumDeviceJoints; ++j) {
    const WorkstationJointSpec& s = kWorkstationJoints[j];
    const double unit = j == kJointInsertion ? 1.0 : kDegree_rad;
    EXPECT_NEAR(s.max_position - s.min_position, spans[j] * unit, 1e-12) << j;
    EXPECT_NEAR(s.resolution, resolutions[j] * unit, 1e-15) << j;
    EXPECT_LT(s.continuous_force, s.peak_force) << j;
  }
  EXPECT_EQ(kWorkstationJoints[kJointInsertion].min_position, 0.0);
  EXPECT_NEAR(kWorkstationJoints[kJointPitch].max_position, 0.87266462599716477, 1e-15);
  EXPECT_EQ(kWorkstationJoints[kJointInsertion].continuous_force, 11.0);
  EXPECT_EQ(kWorkstationJoints[kJointYaw].peak_force, 0.85);
  EXPECT_EQ(kWorkstationJoints[kJointTwist].continuous_force, 0.04);
  EXPECT_EQ(kWorkstationJoints[kJointGrip].continuous_force, 0.15);
  EXPECT_FALSE(is_actuated(kJointTwist));
  EXPECT_TRUE(is_actuated(kJointGrip));
}

}  // namespace
}  // namespace hapticlab
