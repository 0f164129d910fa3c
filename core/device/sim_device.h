#pragma once
// SimDevice, the "sim" backend: a virtual Laparoscopic Surgical Workstation
// (two instruments, five joints each, thesis Table 2.1) that a simulated
// participant holds.
//
// Every joint of every instrument is a mass m_d with Karnopp friction of its
// own, held by the hand through a spring–damper to a moving reference and
// pushed by the motor:
//
//   (m_d + m_h)·ẍ = K·(x_ref(t) − x) + B·(v_ref − ẋ) + f_ff + f_motor − f_friction
//   x_ref(t) = reference_position + reference_velocity·(t − t_set)
//
// integrated by VirtualMass (backward Euler, spring and damper implicit) in
// equal sub-steps of at most max_substep_s, with mechanical end stops at the
// Table 2.1 range (position clamped, outward velocity zeroed). The reading is
// the true position rounded to the nearest sensor count.
//
// Motor: the last write()'s command per joint, clipped to the peak output;
// while a thermal estimate — the exponentially weighted RMS of the output
// over thermal_time_constant_s — exceeds the continuous output, clipped to the
// continuous output instead. The twist is not actuated: its command is
// ignored.
//
// Threads: configure/activate/deactivate/set_position/inject_fault on the
// control thread (not while the loop runs); read/write/set_hand and the
// accessors on the loop thread; halt() and halted() on any thread at any
// time (one atomic flag). read/write/set_hand neither allocate, lock nor do
// I/O.
//
// Not copyable or movable: the loop and the simulated participant hold
// pointers to the one device the hand is on.

#include <array>
#include <atomic>
#include <limits>

#include "core/device/device.h"
#include "core/device/hand_attachment.h"
#include "core/models/virtual_mass.h"

namespace hapticlab {

// Mechanics of one simulated joint. [X], [F], [M] as for HandCoupling.
struct SimJointParams {
  double mass = 0.0;              // [M] > 0, moving mass / rotor inertia
  double static_friction = 0.0;   // [F] >= 0, breakaway
  double dynamic_friction = 0.0;  // [F] >= 0, Coulomb while sliding
  double stick_velocity = 0.0;    // [X/s] >= 0, Karnopp window
};

struct SimDeviceParams {
  // Per DeviceJoint. Defaults: a light, smooth high-end device — the friction
  // is a few percent of the continuous output, far below what the thesis'
  // degradations add (Table 3.1), so the device itself stays in the background.
  std::array<SimJointParams, kNumDeviceJoints> joints = {{
      {0.05, 0.03, 0.03, 1e-4},     // insertion: 50 g carriage, 30 mN Coulomb
      {2e-4, 3e-3, 3e-3, 1e-3},     // pitch: 2e-4 kg·m², 3 mN·m
      {2e-4, 3e-3, 3e-3, 1e-3},     // yaw: as pitch
      {2e-5, 0.3e-3, 0.3e-3, 1e-3},  // twist: handle roll, 0.3 mN·m
      {1e-5, 0.5e-3, 0.5e-3, 1e-3},  // grip: handle jaws, 0.5 mN·m
  }};
  // Time constant of the motor thermal estimate [s], > 0. About that of a
  // small DC motor winding: a peak force is available for a few seconds.
  double thermal_time_constant_s = 10.0;
  // Longest physics sub-step [s], in (0, 1e-3]. 0.25 ms resolves the
  // stiffest hand (~5 kN/m on 50 g) well and is 4 steps at 1 kHz.
  double max_substep_s = 0.25e-3;
  // A read() gap longer than this [s], in [max_substep_s, 10], is a stall:
  // the joint velocities are re-anchored to zero and only the last sub-step
  // is simulated, so a paused loop neither takes long nor injects energy.
  double stall_gap_s = 1.0;
  // A reading more than this many sensor counts outside the mechanical range
  // is reported as kOutOfRange, >= 0.
  double out_of_range_tolerance_counts = 10.0;
};

class SimDevice final : public Device, public HandAttachment {
 public:
  // Throws std::invalid_argument naming the field, the value and its range.
  explicit SimDevice(const SimDeviceParams& params = {});
  SimDevice(const SimDevice&) = delete;
  SimDevice& operator=(const SimDevice&) = delete;

  // --- Device
  // nominal_rate_Hz must lie in [150, 2000] (else kInvalidConfig); kInvalidConfig
  // too while active. The seed is kept for future sensor noise (none today).
  DeviceStatus configure(const DeviceConfig& config) override;
  // Anchors the physics time at clock.now_s(), zeroes the joint velocities and
  // the thermal estimate. `clock` must outlive the activation.
  DeviceStatus activate(const Clock& clock) override;
  // Advances the physics to clock.now_s(), then reports the quantized positions.
  DeviceStatus read(DeviceReading& reading) noexcept override;
  // Stores the command for the next read()'s sub-steps. A non-finite entry
  // never reaches a motor: the whole command becomes zero and the call
  // returns kWriteFailed.
  DeviceStatus write(const DeviceCommand& command) noexcept override;
  DeviceStatus deactivate() noexcept override;
  // Latches the motors at zero (every sub-step, whatever write() stores)
  // until the next activate(), like an amplifier's enable line.
  void halt() noexcept override { halted_.store(true, std::memory_order_release); }
  const char* name() const noexcept override { return "sim"; }
  bool calls_may_block() const noexcept override { return false; }
  HandAttachment* hand_attachment() noexcept override { return this; }

  // --- HandAttachment
  bool set_start_pose(int instrument, const DeviceJoints& position) noexcept override;

  // --- Simulation (not part of Device)
  // Loop thread, between reads. The reference holds from now (the clock's
  // time if active, else the physics time). `instrument` 0 or 1, otherwise
  // ignored. A coupling with a non-finite field or a negative stiffness,
  // damping or mass is not applied: that joint is released (all zero) and
  // rejected_hand_updates() counts it.
  void set_hand(int instrument, const HandCouplings& hand) noexcept override;

  // Control thread, before activate(): the start pose, velocities zero.
  // Throws std::invalid_argument for an instrument other than 0 or 1 or a
  // position that is not finite or outside the mechanical range;
  // std::logic_error while active.
  void set_position(int instrument, const DeviceJoints& position);

  // Fault injection for tests (control thread). From physics time at_time_s
  // on, read() returns `status`:
  //   kReadFailed        the reading is left untouched;
  //   kNonFiniteReading  the reading holds a NaN (instrument 0, insertion);
  //   kOutOfRange        instrument 0's insertion reads 20 mm beyond its end stop;
  //   kWriteFailed       (for write) commands are refused and the motors zeroed;
  //   kTimeout           like kReadFailed, as a device that stops answering;
  //   kNotCalibrated     activate() refuses with it (at_time_s is not used), as
  //                      a device that has not been homed;
  //   kOk                clears an injected fault.
  // The physics keeps running underneath. Throws std::invalid_argument for
  // any other status or a non-finite time.
  void inject_fault(DeviceStatus status, double at_time_s);

  // State of one instrument (0 or 1; any other index gives NaN everywhere).
  DeviceJoints true_position(int instrument) const noexcept;  // [m, rad]
  DeviceJoints velocity(int instrument) const noexcept;       // [m/s, rad/s]
  // What the hand exerted on the handle over the last sub-step,
  // K·(x_ref − x) + B·(v_ref − v) + f_ff [N, N·m]: what the participant feels.
  DeviceJoints hand_force(int instrument) const noexcept override;
  // Motor output in the last sub-step, after the peak and thermal limits.
  DeviceJoints motor_force(int instrument) const noexcept override;
  // Thermal estimate: exponentially weighted RMS of the motor output [N, N·m].
  DeviceJoints thermal_rms_force(int instrument) const noexcept;
  // Physics time [s] (the clock's time at the last read).
  double time_s() const noexcept { return time_s_; }
  int rejected_hand_updates() const noexcept { return rejected_hand_updates_; }
  // Whether halt() latched the motors off since the last activate().
  bool halted() const noexcept { return halted_.load(std::memory_order_acquire); }

  const SimDeviceParams& params() const noexcept { return params_; }

 private:
  struct JointState {
    VirtualMass mass;
    HandCoupling hand;
    double hand_set_time_s = 0.0;  // t_set of the reference
    double command = 0.0;          // last write() [F]
    double motor_force = 0.0;      // applied in the last sub-step [F]
    double heat = 0.0;             // EWMA of motor_force² [F²]
    double hand_force = 0.0;       // [F]
  };
  using Instrument = std::array<JointState, kNumDeviceJoints>;

  void advance_to(double t_s) noexcept;
  void substep(double h_s, double thermal_alpha) noexcept;
  DeviceJoints collect(int instrument, double JointState::*field) const noexcept;
  double now_for_hand() const noexcept;

  SimDeviceParams params_;
  std::array<Instrument, 2> instruments_{};
  const Clock* clock_ = nullptr;
  bool configured_ = false;
  bool active_ = false;
  double time_s_ = 0.0;
  // Motor heating factor of the last sub-step length and time constant: at a
  // steady rate they repeat exactly, and expm1() was ~1 % of a simulated update.
  double thermal_h_s_ = 0.0, thermal_tau_s_ = 0.0, thermal_alpha_ = 0.0;
  DeviceStatus fault_ = DeviceStatus::kOk;
  double fault_time_s_ = std::numeric_limits<double>::infinity();
  int rejected_hand_updates_ = 0;
  bool not_calibrated_ = false;  // injected: activate() refuses
  std::atomic<bool> halted_{false};
};

}  // namespace hapticlab
