#pragma once
// One instrument: three degradation chains (insertion, pitch, yaw) between
// the device and the VE — the thesis' HapticEffect class (2.2.7).
//
//   (dt, joints q, VE tip force F_ve in the world frame)
//     guard         non-finite input => zero force + fault flag
//     tip clip      |F_ve| <= limit (thesis "Force Saturation", 0 = no FFB)
//     loop emul.    F_ve delayed / held
//     world=>joint  F_ve => (F_i, T_pitch, T_yaw)            eq. 2.16–2.18
//     dt policy     dt < 1/2000 s: no time passes yet (carried over); dt > 1/150 s: sub-steps of
//                   <= 1/150 s along the straight line between the two
//                   positions; beyond 8 sub-steps (≈53 ms): re-anchor
//     per DOF       DofChain: friction, cogging, saturation, inertia, backlash
//     device limit  |joint force| <= device limit per axis
//     joint=>world  displayed tip force of the limited commands  eq. 2.19
//     loop emul.    degraded joints delayed / held => VE; offsets eq. 2.20–2.21
//
// Not thread-safe: one instrument is stepped by one (real-time) thread.

#include <array>
#include <cstdint>

#include <Eigen/Core>

#include "core/engine/dof_chain.h"
#include "core/engine/joint_transform.h"
#include "core/engine/loop_emulation.h"
#include "core/settings/settings.h"

namespace hapticlab {

inline constexpr double kMinDt_s = 1.0 / 2000.0;  // fastest rate the models are specified for
inline constexpr double kMaxDt_s = 1.0 / 150.0;   // slowest rate; longer dt is sub-stepped
inline constexpr int kMaxSubsteps = 8;
// Updates in a row that advance no time before the clock counts as stopped
// (kFaultClockStopped): a caller at up to 32 kHz defers at most 16 in a row
// (1/2000 s is 16 of its periods; one more after a re-anchor, which drops
// the time carried so far); at 1 kHz, 20 updates are 20 ms.
inline constexpr int kMaxStalledUpdates = 20;

struct InstrumentInput {
  double dt_s = 0.0;                                          // time since the previous update
  JointVector position = JointVector::Zero();                 // insertion m, pitch rad, yaw rad
  Eigen::Vector3d ve_force_N = Eigen::Vector3d::Zero();       // VE force on the tip, world frame
};

struct InstrumentOutput {
  Eigen::Vector3d displayed_force_N = Eigen::Vector3d::Zero();  // for the device, world frame
  JointVector joint_force = JointVector::Zero();  // insertion N, pitch N·m, yaw N·m (commanded)
  JointVector degraded_position = JointVector::Zero();  // for the VE
  // Tip of degraded_position in the instrument's pivot frame [m]
  // (tip_position(degraded_position)): the trigonometry is done here once,
  // so callers placing the tool in their VE need not redo it.
  Eigen::Vector3d degraded_tip_m = Eigen::Vector3d::Zero();
  // tool_pose(in.position): the pose of the measured joints, for callers that
  // need it too (the simulated hand holding the same device). Valid unless
  // status has kFaultNonFiniteInput or kFaultInvalidArgument.
  ToolPose measured_pose{Eigen::Matrix3d::Identity(), 0.0, 1.0};
  Eigen::Vector3d tip_offset_m = Eigen::Vector3d::Zero();          // eq. 2.20
  Eigen::Matrix3d orientation_offset = Eigen::Matrix3d::Identity();  // eq. 2.21
  std::uint32_t status = 0;                                         // StatusFlag bits
};

class Instrument {
 public:
  Instrument(const EngineSettings& settings, const JointVector& start_position) noexcept;

  InstrumentOutput step(const InstrumentInput& in) noexcept { return step(in, filters_); }
  // The same with Butterworth coefficients from `filters`, a cache that the
  // Engine shares between its two instruments (they see the same dt).
  InstrumentOutput step(const InstrumentInput& in, ButterworthCache& filters) noexcept;

  // The second half of a loop that runs device => engine => VE => engine =>
  // device: `out` is this update's step() result, computed with the VE
  // force the VE gave for the previous positions; `ve_force_N` is what the
  // VE just computed for out.degraded_position. Replaces that force in
  // out.joint_force and out.displayed_force_N, as if step() had been given
  // it, so the VE force reaches the device in the same update. Exact where
  // the VE force only adds to the chain's force (everything but backlash
  // with inertia, whose mass the previous force already moved: those axes
  // keep step()'s force). Does nothing when force latency or hold emulation
  // is on (they define the VE force's timing themselves) or when step()
  // faulted. A non-finite ve_force_N zeroes the forces and sets
  // kFaultNonFiniteInput. Must follow the step() that produced `out`.
  void refresh_forces(const Eigen::Vector3d& ve_force_N, InstrumentOutput& out) noexcept;

  // Takes effect from the next step; see DofChain::on_settings_change.
  void apply_settings(const EngineSettings& settings) noexcept;

 private:
  void resync(const JointVector& q) noexcept;
  // The stages of step(), always inlined: the step is the engine's hot path
  // and the compiler must see it as one body (a call each would cost).
  // dt policy: the time this update advances and in how many sub-steps
  // (resyncing at the measured position when the update must not be
  // integrated).
  struct TimePlan {
    double dt_s = 0.0;
    int substeps = 1;
  };
  [[gnu::always_inline]] TimePlan plan_time(const InstrumentInput& in, const Eigen::Vector3d& ve,
                                            InstrumentOutput& out) noexcept;
  // The degraded joints, delayed/held, as the VE sees them: the degraded
  // position, tip and the display offsets from the measured `pose`.
  [[gnu::always_inline]] void show_degraded(const InstrumentInput& in, const JointVector& degraded,
                                            const ToolPose& pose, const SinCos& pitch, const SinCos& yaw,
                                            InstrumentOutput& out) noexcept;
  // Device limit per axis, then the displayed tip force those limited
  // commands make (eq. 2.19). False, and `out` untouched, if a command is
  // not finite. Always inlined (4 % of an update as a call).
  [[gnu::always_inline]] bool finish_forces(JointVector command, InstrumentOutput& out) const noexcept;
  // A non-finite intermediate value: zero force, state reset at q, status bit 2.
  void internal_fault(const JointVector& q, InstrumentOutput& out) noexcept;
  // The caller's clock stopped: zero force, the VE shown q, re-anchored at
  // the first update that advances time again.
  void clock_stopped(const JointVector& q, InstrumentOutput& out) noexcept;
  // Zero force, no display offsets, the VE shown q (the fault paths).
  void zero_output(const JointVector& q, InstrumentOutput& out) noexcept;

  EngineSettings settings_;
  // AxisTerms of settings_.translation and settings_.rotation.
  std::array<AxisTerms, 2> terms_;
  std::array<DofChain, kNumAxes> chains_;
  JointVector last_position_ = JointVector::Zero();
  JointVector last_degraded_ = JointVector::Zero();
  bool needs_resync_ = true;
  bool anchored_ = false;      // false until the first finite update
  double deferred_dt_s_ = 0.0;  // time of updates too short to advance the models
  int stalled_updates_ = 0;     // updates in a row that advanced no time
  bool clock_stopped_ = false;  // kFaultClockStopped given; re-anchor once time moves
  // Butterworth coefficients of the last sub-step length, unless the caller
  // brings its own cache.
  ButterworthCache filters_;
  // sin/cos of the measured and of the shown pitch and yaw, which repeat
  // while the device rests or a mass sticks in its backlash gap.
  SinCosMemo measured_pitch_, measured_yaw_, shown_pitch_, shown_yaw_;
  // The last sub-step's chain outputs, for refresh_forces.
  std::array<DofOutput, kNumAxes> last_dof_{};
  bool refreshable_ = false;
  SignalDelayHold ve_force_delay_;
  SignalDelayHold position_delay_;
};

}  // namespace hapticlab
