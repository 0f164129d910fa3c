#pragma once
// Kinematics of one laparoscopic instrument pivoting about its trocar
// (thesis 2.2.6.2, Fig. 2-13, eq. 2.16–2.21).
//
// World frame: origin at the trocar (pivot) of this instrument, z up out of
// the patient, so at pitch = yaw = 0 the instrument points along −z. The tool
// orientation is R_w = R_y(−yaw)·R_x(pitch), exactly the matrix of eq. 2.20.
// Its columns give an orthonormal basis at the tool tip:
//   e_yaw   = ( cos y,        0,     sin y       )   lateral, yaw direction
//   e_pitch = (−sin y·sin p,  cos p, cos y·sin p )   lateral, pitch direction
//   d_in    = ( sin y·cos p,  sin p, −cos y·cos p )  = −R_w·e_z, deeper insertion
// and the tip is at insertion·d_in. Positive insertion force pushes toward
// larger insertion; positive pitch/yaw torques turn toward larger angles.
//
// Joint forces are the Jacobian transpose of the world tip force:
//   F_i = d_in·F                      (eq. 2.16)
//   T_pitch = L·(e_pitch·F)           (eq. 2.17, L_pitch = insertion)
//   T_yaw = L·cos(p)·(e_yaw·F)        (eq. 2.18, L_yaw = insertion·cos(pitch))
// and back (eq. 2.19): F = F_i·d_in + T_pitch/L_pitch·e_pitch + T_yaw/L_yaw·e_yaw.
// This agrees with the thesis' printed equations at yaw = 0 and with eq. 2.18
// everywhere; the printed 2.16, 2.17 and 2.19 differ by cos(yaw) factors and a
// sin/cos typo, which would make the two directions disagree (not round-trip).
// See docs/engine.md.

#include <algorithm>
#include <cmath>

#include <Eigen/Core>

#include "core/models/sin_cos.h"

namespace hapticlab {

// (insertion m, pitch rad, yaw rad)
using JointVector = Eigen::Vector3d;

// A pose with its trigonometry done once: every transform of one update
// shares it (the sines and cosines are most of an update's cost).
struct ToolPose {
  Eigen::Matrix3d orientation;  // R_w: columns e_yaw, e_pitch, −d_in
  double insertion_m;
  double cos_pitch;
};
// R_w from the sines and cosines of pitch and yaw.
inline Eigen::Matrix3d tool_orientation(SinCos pitch, SinCos yaw) noexcept {
  const double sp = pitch.sin, cp = pitch.cos;
  const double sy = yaw.sin, cy = yaw.cos;
  Eigen::Matrix3d r;
  // Columns: e_yaw, e_pitch, −d_in (eq. 2.20 with sin(−y) = −sin y).
  r << cy, -sy * sp, -sy * cp,
       0.0, cp, -sp,
       sy, cy * sp, cy * cp;
  return r;
}
inline Eigen::Matrix3d tool_orientation(double pitch_rad, double yaw_rad) noexcept {
  return tool_orientation(sin_cos(pitch_rad), sin_cos(yaw_rad));
}
// The pose of joints (insertion, pitch, yaw) whose angles' sines and cosines
// are given: the engine takes them from memos.
inline ToolPose tool_pose(double insertion_m, SinCos pitch, SinCos yaw) noexcept {
  return {tool_orientation(pitch, yaw), insertion_m, pitch.cos};
}
inline ToolPose tool_pose(const JointVector& q) noexcept {
  return tool_pose(q[0], sin_cos(q[1]), sin_cos(q[2]));
}

Eigen::Vector3d insertion_direction(double pitch_rad, double yaw_rad) noexcept;
Eigen::Vector3d tip_position(const JointVector& q) noexcept;
// insertion·d_in from a pose already computed.
inline Eigen::Vector3d tip_position(const ToolPose& pose) noexcept {
  return -pose.insertion_m * pose.orientation.col(2);
}

// World tip force [N] => (insertion force N, pitch torque N·m, yaw torque N·m).
inline JointVector world_to_joint(const ToolPose& pose, const Eigen::Vector3d& f) noexcept {
  const Eigen::Matrix3d& r = pose.orientation;
  const double arm_pitch = pose.insertion_m;
  const double arm_yaw = pose.insertion_m * pose.cos_pitch;
  // The columns' dot products with f written out, summed in Eigen's order
  // (bit for bit), for the sanitizer build, which did not inline them.
  const auto dot = [&](int column) { return r(0, column) * f[0] + r(1, column) * f[1] + r(2, column) * f[2]; };
  return {-dot(2), arm_pitch * dot(1), arm_yaw * dot(0)};
}
inline JointVector world_to_joint(const JointVector& q, const Eigen::Vector3d& force_N) noexcept {
  return world_to_joint(tool_pose(q), force_N);
}

// Joint forces => world tip force [N]. The moment arms' magnitudes are
// floored at min_moment_arm_m (signs kept) so a tool at the trocar
// (insertion 0) gives finite forces.
inline Eigen::Vector3d joint_to_world(const ToolPose& pose, const JointVector& tau,
                                      double min_moment_arm_m) noexcept {
  // |arm| floored, sign kept: a tip behind the pivot (negative insertion) has
  // its lateral directions reversed, and a floor must not flip them back.
  const auto floored_arm = [min_moment_arm_m](double arm_m) {
    return std::copysign(std::max(std::abs(arm_m), min_moment_arm_m), arm_m);
  };
  const Eigen::Matrix3d& r = pose.orientation;
  const double arm_pitch = floored_arm(pose.insertion_m);
  const double arm_yaw = floored_arm(pose.insertion_m * pose.cos_pitch);
  // -tau0·(third column) + (tau1/arm)·(second) + (tau2/arm)·(first), one
  // component at a time: the same sums in the same order as the Eigen
  // expression it replaces (bit for bit), which the sanitizer build did not
  // inline (6 % of `demo --quick`'s time there).
  const double along_in = -tau[0], pitch = tau[1] / arm_pitch, yaw = tau[2] / arm_yaw;
  return {along_in * r(0, 2) + pitch * r(0, 1) + yaw * r(0, 0),
          along_in * r(1, 2) + pitch * r(1, 1) + yaw * r(1, 0),
          along_in * r(2, 2) + pitch * r(2, 1) + yaw * r(2, 0)};
}
inline Eigen::Vector3d joint_to_world(const JointVector& q, const JointVector& joint_force,
                                      double min_moment_arm_m) noexcept {
  return joint_to_world(tool_pose(q), joint_force, min_moment_arm_m);
}

// Backlash display offsets (eq. 2.20–2.21): where the VE should show the tip
// and how it should rotate the tool, given the instrument's measured joints q
// and the degraded joints q_ve. The tip offset is the exact difference of tip
// positions; eq. 2.20 is its first-order form J(q)·(q_ve − q).
inline Eigen::Vector3d tip_offset(const ToolPose& measured, const ToolPose& shown) noexcept {
  // tip = insertion·d_in = −insertion·(third column of R_w)
  return measured.insertion_m * measured.orientation.col(2) -
         shown.insertion_m * shown.orientation.col(2);
}
inline Eigen::Vector3d tip_offset(const JointVector& q, const JointVector& q_ve) noexcept {
  return tip_offset(tool_pose(q), tool_pose(q_ve));
}
// World-frame rotation taking the measured tool orientation to the degraded
// one: R_w(q_ve)·R_w(q)ᵀ (eq. 2.21 with R_offset,t expressed in the world).
inline Eigen::Matrix3d orientation_offset(const ToolPose& measured, const ToolPose& shown) noexcept {
  return shown.orientation * measured.orientation.transpose();
}
inline Eigen::Matrix3d orientation_offset(const JointVector& q, const JointVector& q_ve) noexcept {
  return orientation_offset(tool_pose(q), tool_pose(q_ve));
}

}  // namespace hapticlab
