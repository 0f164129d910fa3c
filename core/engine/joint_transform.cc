#include "core/engine/joint_transform.h"

#include <algorithm>
#include <cmath>

namespace hapticlab {

Eigen::Matrix3d tool_orientation(double pitch_rad, double yaw_rad) noexcept {
  const double sp = std::sin(pitch_rad), cp = std::cos(pitch_rad);
  const double sy = std::sin(yaw_rad), cy = std::cos(yaw_rad);
  Eigen::Matrix3d r;
  // Columns: e_yaw, e_pitch, −d_in (eq. 2.20 with sin(−y) = −sin y).
  r << cy, -sy * sp, -sy * cp,
       0.0, cp, -sp,
       sy, cy * sp, cy * cp;
  return r;
}

Eigen::Vector3d insertion_direction(double pitch_rad, double yaw_rad) noexcept {
  const double sp = std::sin(pitch_rad), cp = std::cos(pitch_rad);
  const double sy = std::sin(yaw_rad), cy = std::cos(yaw_rad);
  return {sy * cp, sp, -cy * cp};
}

Eigen::Vector3d tip_position(const JointVector& q) noexcept {
  return q[0] * insertion_direction(q[1], q[2]);
}

ToolPose tool_pose(const JointVector& q) noexcept {
  const Eigen::Matrix3d r = tool_orientation(q[1], q[2]);
  return {r, q[0], r(1, 1)};  // r(1,1) = cos(pitch)
}

JointVector world_to_joint(const ToolPose& pose, const Eigen::Vector3d& f) noexcept {
  const Eigen::Matrix3d& r = pose.orientation;
  const double arm_pitch = pose.insertion_m;
  const double arm_yaw = pose.insertion_m * pose.cos_pitch;
  // The columns' dot products with f written out, summed in Eigen's order
  // (bit for bit), for the sanitizer build, which did not inline them.
  const auto dot = [&](int column) { return r(0, column) * f[0] + r(1, column) * f[1] + r(2, column) * f[2]; };
  return {-dot(2), arm_pitch * dot(1), arm_yaw * dot(0)};
}

namespace {
// |arm| floored, sign kept: a tip behind the pivot (negative insertion) has
// its lateral directions reversed, and a floor must not flip them back.
double floored_arm(double arm_m, double min_arm_m) noexcept {
  return std::copysign(std::max(std::abs(arm_m), min_arm_m), arm_m);
}
}  // namespace

Eigen::Vector3d joint_to_world(const ToolPose& pose, const JointVector& tau,
                               double min_moment_arm_m) noexcept {
  const Eigen::Matrix3d& r = pose.orientation;
  const double arm_pitch = floored_arm(pose.insertion_m, min_moment_arm_m);
  const double arm_yaw = floored_arm(pose.insertion_m * pose.cos_pitch, min_moment_arm_m);
  // -tau0·(third column) + (tau1/arm)·(second) + (tau2/arm)·(first), one
  // component at a time: the same sums in the same order as the Eigen
  // expression it replaces (bit for bit), which the sanitizer build did not
  // inline (6 % of `demo --quick`'s time there).
  const double along_in = -tau[0], pitch = tau[1] / arm_pitch, yaw = tau[2] / arm_yaw;
  return {along_in * r(0, 2) + pitch * r(0, 1) + yaw * r(0, 0),
          along_in * r(1, 2) + pitch * r(1, 1) + yaw * r(1, 0),
          along_in * r(2, 2) + pitch * r(2, 1) + yaw * r(2, 0)};
}

Eigen::Vector3d tip_offset(const ToolPose& measured, const ToolPose& shown) noexcept {
  // tip = insertion·d_in = −insertion·(third column of R_w)
  return measured.insertion_m * measured.orientation.col(2) -
         shown.insertion_m * shown.orientation.col(2);
}

Eigen::Matrix3d orientation_offset(const ToolPose& measured, const ToolPose& shown) noexcept {
  return shown.orientation * measured.orientation.transpose();
}

}  // namespace hapticlab
