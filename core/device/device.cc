#include "core/device/device.h"

#include "core/device/workstation_spec.h"

namespace hapticlab {

const char* to_string(DeviceStatus status) noexcept {
  switch (status) {
    case DeviceStatus::kOk: return "ok";
    case DeviceStatus::kNotConfigured: return "not_configured";
    case DeviceStatus::kNotActive: return "not_active";
    case DeviceStatus::kInvalidConfig: return "invalid_config";
    case DeviceStatus::kReadFailed: return "read_failed";
    case DeviceStatus::kNonFiniteReading: return "non_finite_reading";
    case DeviceStatus::kOutOfRange: return "out_of_range";
    case DeviceStatus::kWriteFailed: return "write_failed";
    case DeviceStatus::kEndOfData: return "end_of_data";
    case DeviceStatus::kNotCalibrated: return "not_calibrated";
    case DeviceStatus::kTimeout: return "device_timeout";
    case DeviceStatus::kDeviceCrashed: return "device_crashed";
    case DeviceStatus::kDeviceHung: return "device_hung";
  }
  // A value cast from an integer that names no status (e.g. from the C API).
  return "unknown";
}

}  // namespace hapticlab

namespace hapticlab {

DeviceRatings workstation_ratings() noexcept {
  // Velocity limits are a runaway guard, not a property of the LSW (Table
  // 2.1 gives none): hand motion in laparoscopic tasks stays below about
  // 0.5 m/s at the tip, a few rad/s at the pivot. Four times that still
  // passes any real movement and catches a motor running away or a
  // reading that jumps (1 m in one update is 1000 m/s at 1 kHz). The
  // simulated participant moves faster than a surgeon, and its trials must
  // not trip the guard: over the thesis demo's 135 trials plus the quick
  // demo's 50 it peaked at 1.5 m/s insertion, 4.2 rad/s pitch, 9.8 rad/s
  // grip, and 20.6 rad/s yaw, so insertion, pitch and yaw have about twice
  // that. (The yaw was a fault of participant model 1, whose left hand swung
  // into its end stop in the first 0.15 s of a trial; model 2 turns the
  // shaft at under 2 rad/s. The limits stay: they guard against runaways.)
  static constexpr std::array<double, kNumDeviceJoints> kMaxVelocity = {
      4.0,   // insertion [m/s]
      40.0,  // pitch [rad/s]: 4 m/s at 0.1 m from the pivot
      40.0,  // yaw
      40.0,  // twist: the handle is rolled between the fingers
      40.0,  // grip
  };
  DeviceRatings ratings;
  for (auto& instrument : ratings.joint)
    for (int j = 0; j < kNumDeviceJoints; ++j) {
      const WorkstationJointSpec& spec = kWorkstationJoints[static_cast<std::size_t>(j)];
      instrument[static_cast<std::size_t>(j)] = {spec.min_position, spec.max_position, spec.continuous_force,
                                                 spec.peak_force, kMaxVelocity[static_cast<std::size_t>(j)]};
    }
  return ratings;
}

}  // namespace hapticlab
