#pragma once
// SafetyTrip: why the haptic loop's own safety checks ended a trial, in
// numbers the operator can act on (which instrument and joint, what was
// seen, what was allowed). Plain data: the loop thread fills it before the
// loop ends, any thread reads it after running() is false.
//
// Kinds and what value/limit hold:
//   kPositionOutOfRange  reading [m or rad]; limit_low..limit_high the allowed span
//   kVelocityTooHigh     |joint speed| [m/s or rad/s] between two readings; limit = max_velocity
//   kDeadlineMissed      how late an update started [s]; limit = LoopSafetyConfig::max_lateness_s
//   kLoopStalled         how long the loop had completed no update when the
//                        watchdog halted the device [s]; limit = watchdog_timeout_s
//   kWriterStalled       how long the sample queue had stayed full [s]; limit = writer_stall_s
//   kRateOutOfTolerance  the rate the loop achieved [Hz]; limit = the rate the schedule asked
//                        for [Hz], limit_low = the tolerance (fraction), window_s = the window
//   kDeviceCallHung      how long the device call (call: read or write) had not returned when
//                        the watchdog halted the device [s]; limit = watchdog_timeout_s

#include <cstdint>
#include <string>

namespace hapticlab {

enum class SafetyTripKind : std::uint8_t {
  kNone = 0,
  kPositionOutOfRange,
  kVelocityTooHigh,
  kDeadlineMissed,
  kLoopStalled,
  kWriterStalled,
  kRateOutOfTolerance,
  kDeviceCallHung,
};

// Which device call a kDeviceCallHung trip was in.
// kDeactivate: the loop's last call as it ends (HapticLoop::finish).
enum class DeviceCall : std::uint8_t { kNone = 0, kRead, kWrite, kDeactivate };
const char* to_string(DeviceCall call) noexcept;  // "read", "write", "deactivate", "none"

struct SafetyTrip {
  SafetyTripKind kind = SafetyTripKind::kNone;
  int instrument = -1;  // 0 left, 1 right; -1 when not about a joint
  int joint = -1;       // DeviceJoint; -1 when not about a joint
  double value = 0.0;
  double limit = 0.0;       // the upper limit (or the only one)
  double limit_low = 0.0;   // kPositionOutOfRange: the lower end of the allowed span
  double window_s = 0.0;    // kRateOutOfTolerance: how long the rate was measured over [s]
  DeviceCall call = DeviceCall::kNone;  // kDeviceCallHung
  // kLoopStalled, kDeviceCallHung: the device did not confirm the watchdog's
  // halt (Device::halt_unconfirmed): it may still hold its last force.
  bool halt_unconfirmed = false;

  bool tripped() const noexcept { return kind != SafetyTripKind::kNone; }
};

// "position_out_of_range", "velocity_too_high", "deadline_missed",
// "loop_stalled", "writer_stalled", "rate_out_of_tolerance",
// "device_call_hung", "none".
const char* to_string(SafetyTripKind kind) noexcept;

// One sentence for the operator and the trial's abort reason, e.g.
// "right instrument insertion read 1.1 m, outside the allowed -0.0085..0.1785 m".
// Allocates: control thread only.
std::string describe(const SafetyTrip& trip);

}  // namespace hapticlab
