#include "core/loop/force_guard.h"

#include <algorithm>
#include <cmath>

namespace hapticlab {
namespace {

double group_limit(const OperatorForceLimits& limits, int joint) noexcept {
  switch (joint) {
    case kJointInsertion: return limits.insertion_force_N;
    case kJointPitch:
    case kJointYaw: return limits.pitch_yaw_torque_Nm;
    case kJointTwist: return limits.twist_torque_Nm;
    case kJointGrip: return limits.grip_torque_Nm;
  }
  return 0.0;
}

// NaN and negative limits fail closed: std::min would pass a NaN through
// depending on the argument order.
double non_negative_or_zero(double x) noexcept { return x >= 0.0 ? x : 0.0; }

}  // namespace

ForceGuard::ForceGuard() noexcept = default;

ForceGuard::ForceGuard(const DeviceRatings& ratings, const OperatorForceLimits& limits, double ramp_in_s) noexcept
    : ramp_in_s_(ramp_in_s > 0.0 ? ramp_in_s : 0.0) {
  const double fraction = std::clamp(non_negative_or_zero(limits.peak_force_fraction), 0.0, 1.0);
  for (int i = 0; i < 2; ++i) {
    for (int j = 0; j < kNumDeviceJoints; ++j) {
      const double peak = ratings.joint[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)].peak_force;
      const double device = std::isfinite(peak) ? non_negative_or_zero(peak) : 0.0;
      const double group = non_negative_or_zero(group_limit(limits, j));
      limit_[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)] = std::min({device, fraction * device, group});
    }
  }
}

double ForceGuard::ramp_scale(double t_s) const noexcept {
  if (!(t_s > 0.0)) return ramp_in_s_ > 0.0 ? 0.0 : 1.0;
  if (t_s >= ramp_in_s_) return 1.0;
  return t_s / ramp_in_s_;
}

int ForceGuard::apply(DeviceCommand& command, double t_s) const noexcept {
  const double scale = ramp_scale(t_s);
  int limited = 0;
  for (std::size_t i = 0; i < 2; ++i) {
    for (std::size_t j = 0; j < static_cast<std::size_t>(kNumDeviceJoints); ++j) {
      double& f = command.force[i][j];
      const double lim = limit_[i][j];
      if (!std::isfinite(f)) {
        f = 0.0;
        ++limited;
        continue;
      }
      const double scaled = scale * f;
      f = std::clamp(scaled, -lim, lim);
      if (f != scaled) ++limited;
    }
  }
  return limited;
}

double ForceGuard::limit(int instrument, int joint) const noexcept {
  if ((instrument != 0 && instrument != 1) || joint < 0 || joint >= kNumDeviceJoints) return 0.0;
  return limit_[static_cast<std::size_t>(instrument)][static_cast<std::size_t>(joint)];
}

}  // namespace hapticlab
