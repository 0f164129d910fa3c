#pragma once
// ForceGuard: the last stage before a force command reaches the motors, on
// every update, for every instrument and DeviceJoint (grip included):
//
//   (engine joint forces, VE grip torque, t since the loop started)
//     => f_cmd = clamp(s(t)·f, −limit, +limit), s(t) = min(1, t / ramp_in_s)
//   limit = min(peak_force of the device's rating,
//               peak_force_fraction · peak_force, the operator's joint-group limit)
//
// The ramp-in: the first update commands zero and the force reaches full
// scale after ramp_in_s, so a trial never begins with a step to a large
// force (a VE that starts in contact, a degradation with a standing force).
// A non-finite entry becomes 0. A rating that is not a finite number >= 0
// gives a limit of 0 on that joint: an unknown device is not driven.
//
// apply() is real-time safe (no allocation, locks or I/O).

#include <limits>

#include "core/device/device.h"

namespace hapticlab {

// Limits the operator sets below the device's own (the protocol's "safety"
// object, docs/safety.md). Defaults leave the device's peak output.
struct OperatorForceLimits {
  static constexpr double kNoLimit = std::numeric_limits<double>::infinity();
  double peak_force_fraction = 1.0;          // [0, 1] of every joint's peak_force
  double insertion_force_N = kNoLimit;       // >= 0 [N]
  double pitch_yaw_torque_Nm = kNoLimit;     // >= 0 [N·m], pitch and yaw
  double twist_torque_Nm = kNoLimit;         // >= 0 [N·m]
  double grip_torque_Nm = kNoLimit;          // >= 0 [N·m]
};

class ForceGuard {
 public:
  // The default ramp-in of every backend (the loop's, and the study API's
  // trial engines) [s]. 0.3 s is longer than a stretch reflex (~0.1 s), so
  // the hand takes up the load instead of being jolted by it, and short
  // against a task's tens of seconds (the simulated participant is still
  // entering the trocar then).
  static constexpr double kDefaultRampIn_s = 0.3;

  // Default: ramp 0 and limits of 0 everywhere (nothing reaches a motor
  // until the loop builds a guard from the device's ratings).
  ForceGuard() noexcept;
  // ramp_in_s >= 0 (0: no ramp; NaN or negative is taken as 0).
  ForceGuard(const DeviceRatings& ratings, const OperatorForceLimits& limits, double ramp_in_s) noexcept;

  // Ramp scale at loop time t_s [s]: 0 at t <= 0, 1 from ramp_in_s on.
  double ramp_scale(double t_s) const noexcept;
  // Scales by the ramp and clamps `command` in place. Returns how many
  // entries the limit (not the ramp) changed, non-finite ones included.
  int apply(DeviceCommand& command, double t_s) const noexcept;
  // The magnitude limit of one instrument's joint [N or N·m].
  double limit(int instrument, int joint) const noexcept;
  double ramp_in_s() const noexcept { return ramp_in_s_; }

 private:
  std::array<DeviceJoints, 2> limit_{};
  double ramp_in_s_ = 0.0;
};

}  // namespace hapticlab
