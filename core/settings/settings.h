#pragma once
// Everything the engine needs for one configuration ("setting" in the thesis'
// sense: High Fidelity, Friction, All Degradations, ...). Plain data, so it can
// be copied into the real-time thread without allocation.

#include <array>
#include <string>

#include "core/settings/axis_settings.h"

namespace hapticlab {

// The three actuated DOF of one instrument, in this order everywhere.
enum Axis : int { kInsertion = 0, kPitch = 1, kYaw = 2 };
inline constexpr int kNumAxes = 3;
inline constexpr int kNumInstruments = 2;

// Magnitude clip of the VE tool-tip force in the world frame, before it is
// transformed to the joints. This is the thesis' "Force Saturation" setting
// (Table 3.1: 1 N, rotation N/A); a limit of 0 is "No Force Feedback".
struct TipForceSaturation {
  bool enabled = false;
  double limit_N = 0.0;
};

// Emulation of a slower or later control loop (beyond the thesis). The
// degradation models keep running at the real rate, because they stand for
// physical hardware; what is held or delayed is the exchange with the VE:
// the positions sent to it and the force received from it.
struct LoopEmulation {
  double hold_rate_Hz = 0.0;          // 0 = off; else the emulated loop rate, <= 2000 Hz
  double position_latency_s = 0.0;    // 0..0.1 s delay of positions sent to the VE
  double force_latency_s = 0.0;       // 0..0.1 s delay of the VE force
};

// Safety limits of the physical device, applied last, per joint (motor axis),
// whatever the other parameters. Defaults: peak output of the Laparoscopic Surgical
// Workstation, thesis Table 2.1.
struct DeviceLimits {
  double insertion_force_N = 19.0;
  double pitch_torque_Nm = 0.85;
  double yaw_torque_Nm = 0.85;
};

struct EngineSettings {
  AxisSettings translation;  // insertion
  AxisSettings rotation;     // pitch and yaw
  TipForceSaturation tip_force_saturation;
  LoopEmulation loop;
  DeviceLimits device_limits;
  // Smallest moment arm used to turn pitch/yaw torques into tip forces; the
  // pivot-to-tip distance is the insertion, which can be 0 at the trocar.
  double min_moment_arm_m = 0.02;

  const AxisSettings& axis(int a) const { return a == kInsertion ? translation : rotation; }
  double device_limit(int a) const {
    return a == kInsertion ? device_limits.insertion_force_N
           : a == kPitch   ? device_limits.pitch_torque_Nm
                           : device_limits.yaw_torque_Nm;
  }
};

}  // namespace hapticlab
