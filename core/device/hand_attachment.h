#pragma once
// A simulated device that a simulated participant holds: the participant's
// hand is part of the device's physics (a spring–damper to a moving
// reference, see SimDevice), so the participant acts on it through this
// interface rather than through forces. Real hardware has no attachment; a
// person holds it.
//
// Why an interface and not SimDevice: the simulated workstation also runs
// as a device plugin and behind the UDP bridge, and the participant must
// drive all three the same way (the test suite checks they log identical
// samples).
//
// Threads as for SimDevice: set_position on the control thread before
// activate(); the rest on the loop thread, between read() and write(),
// real-time safe.

#include "core/device/device.h"

namespace hapticlab {

// The simulated hand on one joint. [X] = m for insertion, rad otherwise;
// [F] = N or N·m; [M] = kg or kg·m². All zero: the hand is off the joint.
struct HandCoupling {
  double reference_position = 0.0;  // [X] where the hand wants the joint at the time of set_hand
  double reference_velocity = 0.0;  // [X/s] the reference moves on linearly until the next set_hand
  double stiffness = 0.0;           // [F/X] >= 0, hand impedance
  double damping = 0.0;             // [F·s/X] >= 0
  double force = 0.0;               // [F] feed-forward push
  double mass = 0.0;                // [M] hand/arm mass moving with the handle, >= 0
};
using HandCouplings = std::array<HandCoupling, kNumDeviceJoints>;

class HandAttachment {
 public:
  virtual ~HandAttachment() = default;
  // The start pose of one instrument (0 or 1), velocities zero. Returns
  // false for a bad instrument, a pose outside the mechanical range, or
  // while active.
  virtual bool set_start_pose(int instrument, const DeviceJoints& position) noexcept = 0;
  // The hand's coupling from now on (the loop clock's time of the current
  // update). A coupling with a non-finite field or a negative stiffness,
  // damping or mass releases that joint instead.
  virtual void set_hand(int instrument, const HandCouplings& hand) noexcept = 0;
  // What the hand exerted on the handle over the last physics sub-step [N, N·m].
  virtual DeviceJoints hand_force(int instrument) const noexcept = 0;
  // Motor output in the last sub-step, after the device's limits [N, N·m].
  virtual DeviceJoints motor_force(int instrument) const noexcept = 0;
};

}  // namespace hapticlab
