#pragma once
// Where the two instruments enter the simulated abdomen, and the conversions
// between joint space (insertion, pitch, yaw; core/engine/joint_transform.h)
// and the VE's world frame.
//
// VE world frame: origin midway between the two trocars, x to the right,
// y away from the surgeon, z up. Each instrument's joint frame is the world
// frame translated to its trocar, so tip_world = trocar + tip_position(q).
// The task's tissue lies about 110 mm below the trocars: inside the LSW's
// 170 mm insertion range and within ±35° of pitch and yaw.

#include <algorithm>
#include <array>
#include <cmath>

#include <Eigen/Core>

#include "core/engine/joint_transform.h"

namespace hapticlab {

inline constexpr double kTrocarSpacing_m = 0.10;
inline const std::array<Eigen::Vector3d, 2> kTrocarPosition_m = {
    Eigen::Vector3d(-0.5 * kTrocarSpacing_m, 0.0, 0.0),
    Eigen::Vector3d(0.5 * kTrocarSpacing_m, 0.0, 0.0)};

// Insertion at which the thesis starts the completion-time clock (3.3.5.1).
inline constexpr double kInsertionMark_m = 0.020;

inline Eigen::Vector3d tip_world(int instrument, const JointVector& q) noexcept {
  return kTrocarPosition_m[static_cast<std::size_t>(instrument)] + tip_position(q);
}

// Joint coordinates that put the tip at `p_world`. Inverse of tip_world for
// insertion > 0: insertion = |p|, pitch = asin(p_y/|p|), yaw = atan2(p_x, −p_z)
// with p relative to the trocar.
inline JointVector joints_for_tip(int instrument, const Eigen::Vector3d& p_world) noexcept {
  const Eigen::Vector3d p = p_world - kTrocarPosition_m[static_cast<std::size_t>(instrument)];
  const double insertion_m = p.norm();
  if (insertion_m < 1e-9) return JointVector::Zero();
  return {insertion_m, std::asin(std::clamp(p.y() / insertion_m, -1.0, 1.0)),
          std::atan2(p.x(), -p.z())};
}

}  // namespace hapticlab
