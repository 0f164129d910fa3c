#include "core/engine/joint_transform.h"

namespace hapticlab {

Eigen::Vector3d insertion_direction(double pitch_rad, double yaw_rad) noexcept {
  const SinCos pitch = sin_cos(pitch_rad), yaw = sin_cos(yaw_rad);
  return {yaw.sin * pitch.cos, pitch.sin, -yaw.cos * pitch.cos};
}

Eigen::Vector3d tip_position(const JointVector& q) noexcept {
  return q[0] * insertion_direction(q[1], q[2]);
}

}  // namespace hapticlab
