#include "core/loop/safety_trip.h"

#include <cstdio>

#include "core/device/device.h"

namespace hapticlab {
namespace {

const char* joint_name(int joint) noexcept {
  switch (joint) {
    case kJointInsertion: return "insertion";
    case kJointPitch: return "pitch";
    case kJointYaw: return "yaw";
    case kJointTwist: return "twist";
    case kJointGrip: return "grip";
  }
  return "joint ?";
}

const char* instrument_name(int instrument) noexcept {
  return instrument == 0 ? "left" : instrument == 1 ? "right" : "?";
}

// Insertion is linear, every other joint rotates.
const char* unit(int joint) noexcept { return joint == kJointInsertion ? "m" : "rad"; }

std::string format(const char* pattern, double a, double b = 0.0, double c = 0.0) {
  char buffer[160];
  std::snprintf(buffer, sizeof buffer, pattern, a, b, c);
  return buffer;
}

}  // namespace

const char* to_string(SafetyTripKind kind) noexcept {
  switch (kind) {
    case SafetyTripKind::kNone: return "none";
    case SafetyTripKind::kPositionOutOfRange: return "position_out_of_range";
    case SafetyTripKind::kVelocityTooHigh: return "velocity_too_high";
    case SafetyTripKind::kDeadlineMissed: return "deadline_missed";
    case SafetyTripKind::kLoopStalled: return "loop_stalled";
    case SafetyTripKind::kWriterStalled: return "writer_stalled";
    case SafetyTripKind::kRateOutOfTolerance: return "rate_out_of_tolerance";
    case SafetyTripKind::kDeviceCallHung: return "device_call_hung";
  }
  return "unknown";
}

const char* to_string(DeviceCall call) noexcept {
  switch (call) {
    case DeviceCall::kNone: return "none";
    case DeviceCall::kRead: return "read";
    case DeviceCall::kWrite: return "write";
    case DeviceCall::kDeactivate: return "deactivate";
  }
  return "unknown";
}

namespace {

std::string halt_outcome(const SafetyTrip& trip) {
  return trip.halt_unconfirmed ? "; a halt was sent to the device, which did not confirm it: it may still hold its "
                                 "last force (switch its amplifiers off)"
                               : "; the device was halted";
}

}  // namespace

std::string describe(const SafetyTrip& trip) {
  const std::string joint =
      std::string(instrument_name(trip.instrument)) + " instrument " + joint_name(trip.joint);
  const std::string u = unit(trip.joint);
  switch (trip.kind) {
    case SafetyTripKind::kNone: return "no safety trip";
    case SafetyTripKind::kPositionOutOfRange:
      return joint + format(" read %.6g ", trip.value) + u +
             format(", outside the allowed %.6g..%.6g ", trip.limit_low, trip.limit) + u;
    case SafetyTripKind::kVelocityTooHigh:
      return joint + format(" moved at %.6g ", trip.value) + u +
             format("/s, above its limit of %.6g ", trip.limit) + u + "/s";
    case SafetyTripKind::kDeadlineMissed:
      return format("an update started %.1f ms late (limit %.1f ms)", 1e3 * trip.value, 1e3 * trip.limit);
    case SafetyTripKind::kLoopStalled:
      return format("the loop completed no update for %.1f ms (limit %.1f ms)", 1e3 * trip.value,
                    1e3 * trip.limit) +
             halt_outcome(trip);
    case SafetyTripKind::kWriterStalled:
      return format("the sample writer fell behind: the sample queue stayed full for %.3f s (limit %.3f s)",
                    trip.value, trip.limit);
    case SafetyTripKind::kRateOutOfTolerance:
      return format("the loop ran at %.1f Hz where the schedule asked for %.1f Hz", trip.value, trip.limit) +
             format(" (%+.1f %%, tolerance %.1f %%", 100.0 * (trip.value / trip.limit - 1.0), 100.0 * trip.limit_low) +
             format(", over %.2f s)", trip.window_s);
    case SafetyTripKind::kDeviceCallHung:
      return std::string("device ") + to_string(trip.call) +
             format(" hung for %.0f ms (watchdog limit %.0f ms)", 1e3 * trip.value, 1e3 * trip.limit) +
             halt_outcome(trip);
  }
  return "unknown safety trip";
}

}  // namespace hapticlab
