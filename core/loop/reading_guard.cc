#include "core/loop/reading_guard.h"

#include <cmath>

namespace hapticlab {

ReadingGuard::ReadingGuard(const DeviceRatings& ratings, double position_tolerance_fraction) noexcept
    : ratings_(ratings), tolerance_fraction_(position_tolerance_fraction > 0.0 ? position_tolerance_fraction : 0.0) {}

void ReadingGuard::reset() noexcept {
  anchored_ = false;
  since_reference_s_ = 0.0;
}

SafetyTrip ReadingGuard::check(const DeviceReading& reading, double dt_s) noexcept {
  // (reading, ratings) => position trip: the first joint outside its span.
  for (int i = 0; i < 2; ++i) {
    for (int j = 0; j < kNumDeviceJoints; ++j) {
      const DeviceJointRating& r = ratings_.joint[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
      const double tolerance = tolerance_fraction_ * (r.max_position - r.min_position);
      const double low = r.min_position - tolerance;
      const double high = r.max_position + tolerance;
      const double x = reading.position[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
      // Written so that NaN, in the reading or in the rating, trips.
      if (!(x >= low && x <= high)) {
        SafetyTrip trip;
        trip.kind = SafetyTripKind::kPositionOutOfRange;
        trip.instrument = i;
        trip.joint = j;
        trip.value = x;
        trip.limit_low = low;
        trip.limit = high;
        return trip;
      }
    }
  }

  // (reading, reference, elapsed) => velocity trip, once the window is long enough.
  if (!anchored_) {
    reference_ = reading.position;
    since_reference_s_ = 0.0;
    anchored_ = true;
    return {};
  }
  if (dt_s > 0.0 && std::isfinite(dt_s)) since_reference_s_ += dt_s;
  if (since_reference_s_ < kMinVelocityWindow_s) return {};
  for (int i = 0; i < 2; ++i) {
    for (int j = 0; j < kNumDeviceJoints; ++j) {
      const auto ui = static_cast<std::size_t>(i);
      const auto uj = static_cast<std::size_t>(j);
      const double speed = std::abs(reading.position[ui][uj] - reference_[ui][uj]) / since_reference_s_;
      const double limit = ratings_.joint[ui][uj].max_velocity;
      if (!(speed <= limit)) {
        SafetyTrip trip;
        trip.kind = SafetyTripKind::kVelocityTooHigh;
        trip.instrument = i;
        trip.joint = j;
        trip.value = speed;
        trip.limit = limit;
        return trip;
      }
    }
  }
  reference_ = reading.position;
  since_reference_s_ = 0.0;
  return {};
}

}  // namespace hapticlab
