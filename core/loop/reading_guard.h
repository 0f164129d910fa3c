#pragma once
// ReadingGuard: checks every device reading against the device's ratings
// before anything is computed from it.
//
//   position: x in [min_position − tol, max_position + tol],
//             tol = position_tolerance_fraction · (max_position − min_position)
//   velocity: |x − x_ref| / (t − t_ref) <= max_velocity, where x_ref is the
//             reading at least kMinVelocityWindow_s earlier (the measured
//             dt of the updates in between, summed)
//
// The tolerance lets a real device read a little past its nominal end
// stops (compliant stops, homing offsets) without a fault; a reading far
// outside (a jump of 1 m, a wrong unit, a lost encoder) is one. The
// velocity window keeps a one-count change over a very short dt (an update
// right after a late one) from looking like a runaway: at 0.5 ms one count
// of the LSW's insertion encoder is 0.016 m/s, far below any limit, while
// a 1 m jump is still 2000 m/s. The first reading after reset() only
// anchors the velocity check.
//
// check() is real-time safe (no allocation, locks or I/O).

#include "core/device/device.h"
#include "core/loop/safety_trip.h"

namespace hapticlab {

class ReadingGuard {
 public:
  static constexpr double kMinVelocityWindow_s = 0.5e-3;
  static constexpr double kDefaultPositionToleranceFraction = 0.05;

  // position_tolerance_fraction >= 0 (NaN or negative is taken as 0).
  explicit ReadingGuard(const DeviceRatings& ratings = workstation_ratings(),
                        double position_tolerance_fraction = kDefaultPositionToleranceFraction) noexcept;

  // Forget the previous reading (a new activation).
  void reset() noexcept;
  // dt_s: time since the previous check() [s], as the loop measured it.
  // Returns a trip of kind kNone when the reading is acceptable; the first
  // joint that is not, otherwise (position before velocity). A NaN
  // reading fails the position check.
  SafetyTrip check(const DeviceReading& reading, double dt_s) noexcept;

 private:
  DeviceRatings ratings_;
  double tolerance_fraction_;
  bool anchored_ = false;
  std::array<DeviceJoints, 2> reference_{};
  double since_reference_s_ = 0.0;
};

}  // namespace hapticlab
