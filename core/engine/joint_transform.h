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

#include <Eigen/Core>

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
ToolPose tool_pose(const JointVector& q) noexcept;

Eigen::Matrix3d tool_orientation(double pitch_rad, double yaw_rad) noexcept;
Eigen::Vector3d insertion_direction(double pitch_rad, double yaw_rad) noexcept;
Eigen::Vector3d tip_position(const JointVector& q) noexcept;
// insertion·d_in from a pose already computed.
inline Eigen::Vector3d tip_position(const ToolPose& pose) noexcept {
  return -pose.insertion_m * pose.orientation.col(2);
}

// World tip force [N] => (insertion force N, pitch torque N·m, yaw torque N·m).
JointVector world_to_joint(const ToolPose& pose, const Eigen::Vector3d& force_N) noexcept;
inline JointVector world_to_joint(const JointVector& q, const Eigen::Vector3d& force_N) noexcept {
  return world_to_joint(tool_pose(q), force_N);
}

// Joint forces => world tip force [N]. The moment arms' magnitudes are
// floored at min_moment_arm_m (signs kept) so a tool at the trocar
// (insertion 0) gives finite forces.
Eigen::Vector3d joint_to_world(const ToolPose& pose, const JointVector& joint_force,
                               double min_moment_arm_m) noexcept;
inline Eigen::Vector3d joint_to_world(const JointVector& q, const JointVector& joint_force,
                                      double min_moment_arm_m) noexcept {
  return joint_to_world(tool_pose(q), joint_force, min_moment_arm_m);
}

// Backlash display offsets (eq. 2.20–2.21): where the VE should show the tip
// and how it should rotate the tool, given the instrument's measured joints q
// and the degraded joints q_ve. The tip offset is the exact difference of tip
// positions; eq. 2.20 is its first-order form J(q)·(q_ve − q).
Eigen::Vector3d tip_offset(const ToolPose& measured, const ToolPose& shown) noexcept;
inline Eigen::Vector3d tip_offset(const JointVector& q, const JointVector& q_ve) noexcept {
  return tip_offset(tool_pose(q), tool_pose(q_ve));
}
// World-frame rotation taking the measured tool orientation to the degraded
// one: R_w(q_ve)·R_w(q)ᵀ (eq. 2.21 with R_offset,t expressed in the world).
Eigen::Matrix3d orientation_offset(const ToolPose& measured, const ToolPose& shown) noexcept;
inline Eigen::Matrix3d orientation_offset(const JointVector& q, const JointVector& q_ve) noexcept {
  return orientation_offset(tool_pose(q), tool_pose(q_ve));
}

}  // namespace hapticlab
