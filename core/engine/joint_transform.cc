#include "core/engine/joint_transform.h"

#include <cmath>

namespace hapticlab {

Eigen::Vector3d insertion_direction(double pitch_rad, double yaw_rad) noexcept {
  const double sp = std::sin(pitch_rad), cp = std::cos(pitch_rad);
  const double sy = std::sin(yaw_rad), cy = std::cos(yaw_rad);
  return {sy * cp, sp, -cy * cp};
}

Eigen::Vector3d tip_position(const JointVector& q) noexcept {
  return q[0] * insertion_direction(q[1], q[2]);
}

}  // namespace hapticlab
