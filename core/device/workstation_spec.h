#pragma once
// Immersion Laparoscopic Surgical Workstation (LSW), thesis Table 2.1, in SI.
//
//                 range        cont. output  peak output  sensor res.
//   insertion     170 mm       11.0 N        19.0 N       0.008 mm
//   pitch         100°         0.47 N·m      0.85 N·m     0.01°
//   yaw           100°         0.47 N·m      0.85 N·m     0.01°
//   handle twist  180°         0.04 N·m      0.07 N·m     0.03°
//   handle grip   20°          0.15 N·m      0.32 N·m     0.04°
//
// The table gives the span of each joint; where it sits is our convention
// (README): insertion 0 at the trocar, so 0..0.170 m; pitch, yaw and twist
// centred on the tool's rest pose (±50°, ±50°, ±90°); grip 0 = closed,
// 0..20°. The virtual tip twist (continuous, 0.7°, unactuated, not a
// physical joint) is not a DeviceJoint and has no entry here.
//
// The table lists a continuous and a peak output for the twist, but the LSW
// does not actuate it (device.h): a twist command is ignored.

#include <array>
#include <numbers>

#include "core/device/device.h"

namespace hapticlab {

inline constexpr double kDegree_rad = std::numbers::pi / 180.0;

// --- range [m] / [rad]
inline constexpr double kLswInsertionMin_m = 0.0;
inline constexpr double kLswInsertionMax_m = 0.170;
inline constexpr double kLswPitchYawHalfRange_rad = 50.0 * kDegree_rad;  // 100° span
inline constexpr double kLswTwistHalfRange_rad = 90.0 * kDegree_rad;     // 180° span
inline constexpr double kLswGripMin_rad = 0.0;
inline constexpr double kLswGripMax_rad = 20.0 * kDegree_rad;

// --- continuous / peak output [N] / [N·m]
inline constexpr double kLswInsertionContinuousForce_N = 11.0;
inline constexpr double kLswInsertionPeakForce_N = 19.0;
inline constexpr double kLswPitchYawContinuousTorque_Nm = 0.47;
inline constexpr double kLswPitchYawPeakTorque_Nm = 0.85;
inline constexpr double kLswTwistContinuousTorque_Nm = 0.04;
inline constexpr double kLswTwistPeakTorque_Nm = 0.07;
inline constexpr double kLswGripContinuousTorque_Nm = 0.15;
inline constexpr double kLswGripPeakTorque_Nm = 0.32;

// --- sensor resolution: one encoder count [m] / [rad]
inline constexpr double kLswInsertionResolution_m = 0.008e-3;
inline constexpr double kLswPitchYawResolution_rad = 0.01 * kDegree_rad;
inline constexpr double kLswTwistResolution_rad = 0.03 * kDegree_rad;
inline constexpr double kLswGripResolution_rad = 0.04 * kDegree_rad;

// One joint's row of Table 2.1. [X] = m for insertion, rad otherwise;
// [F] = N for insertion, N·m otherwise.
struct WorkstationJointSpec {
  double min_position;      // [X] lower mechanical end stop
  double max_position;      // [X] upper mechanical end stop
  double continuous_force;  // [F] sustainable output magnitude
  double peak_force;        // [F] short-term output magnitude
  double resolution;        // [X] one sensor count
};

// Indexed by DeviceJoint.
inline constexpr std::array<WorkstationJointSpec, kNumDeviceJoints> kWorkstationJoints = {{
    {kLswInsertionMin_m, kLswInsertionMax_m, kLswInsertionContinuousForce_N,
     kLswInsertionPeakForce_N, kLswInsertionResolution_m},
    {-kLswPitchYawHalfRange_rad, kLswPitchYawHalfRange_rad, kLswPitchYawContinuousTorque_Nm,
     kLswPitchYawPeakTorque_Nm, kLswPitchYawResolution_rad},
    {-kLswPitchYawHalfRange_rad, kLswPitchYawHalfRange_rad, kLswPitchYawContinuousTorque_Nm,
     kLswPitchYawPeakTorque_Nm, kLswPitchYawResolution_rad},
    {-kLswTwistHalfRange_rad, kLswTwistHalfRange_rad, kLswTwistContinuousTorque_Nm,
     kLswTwistPeakTorque_Nm, kLswTwistResolution_rad},
    {kLswGripMin_rad, kLswGripMax_rad, kLswGripContinuousTorque_Nm, kLswGripPeakTorque_Nm,
     kLswGripResolution_rad},
}};

// Whether the LSW drives this joint with a motor (all but the handle twist).
constexpr bool is_actuated(DeviceJoint joint) noexcept { return joint != kJointTwist; }

static_assert(kWorkstationJoints[kJointInsertion].max_position == 0.170);
static_assert(kWorkstationJoints[kJointGrip].peak_force == 0.32);

}  // namespace hapticlab
