#include "core/engine/instrument.h"

#include <bit>
#include <cmath>
#include <cstdint>

#include "core/engine/status.h"
#include "core/models/saturation.h"

namespace hapticlab {
namespace {

// x·0 is ±0 for a finite x and NaN for an infinite or NaN one, so one
// comparison checks several values without a branch for each (Eigen's
// allFinite(), (v - v).hasNaN(), was 5 % of `demo --quick`'s time in the
// sanitizer build, which does not inline it).
bool finite(const Eigen::Vector3d& v) noexcept {
  return v.x() * 0.0 + v.y() * 0.0 + v.z() * 0.0 == 0.0;
}
bool finite(double dt, const Eigen::Vector3d& a, const Eigen::Vector3d& b) noexcept {
  return dt * 0.0 + (a.x() * 0.0 + a.y() * 0.0 + a.z() * 0.0) + (b.x() * 0.0 + b.y() * 0.0 + b.z() * 0.0) == 0.0;
}

// Whether two doubles have the same bits, so that a function of one is,
// exactly, the function of the other (0.0 == −0.0, but their sines differ).
bool same_bits(double a, double b) noexcept {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}

[[gnu::always_inline]] inline Eigen::Vector3d clip_magnitude(const Eigen::Vector3d& f, double limit) noexcept {
  // Well inside the limit (the usual case) the force is returned as it is,
  // as below, without the divisions: |f|² <= limit²·(1 − 1e-9) puts
  // largest·scaled_norm (|f| within 4 ulps) below the limit. An overflowing
  // |f|² takes the long way, and so does a limit whose square would
  // underflow (0 included: a tiny force's |f|² would be 0 too, yet the long
  // way clips it to zero).
  if (limit >= 1e-100 && f.squaredNorm() <= limit * limit * (1.0 - 1e-9)) return f;
  // Scaled by the largest component first: the norm of a finite force near
  // 1e308 N overflows (norm() already at 1e154 N, hypot() at 1.3e308 N), and
  // limit/inf would zero the force instead of clipping it.
  const double largest = f.cwiseAbs().maxCoeff();
  if (largest == 0.0) return f;
  const Eigen::Vector3d scaled = f / largest;  // largest component ±1
  const double scaled_norm = scaled.norm();    // 1 .. sqrt(3)
  return largest * scaled_norm > limit ? Eigen::Vector3d(scaled * (limit / scaled_norm)) : f;
}

// Field by field: a copy of the whole struct reads it back 16 bytes at a
// time over the 8-byte stores that built it, and the processor cannot
// forward such a load from those stores (a stall per axis: 9 % of `bench
// engine`'s samples sat on the instruction after it).
[[gnu::always_inline]] inline void keep_fields(const DofOutput& d, DofOutput& kept) noexcept {
  kept.force = d.force;
  kept.position = d.position;
  kept.model_force = d.model_force;
  kept.ripple = d.ripple;
  kept.ve_coupled = d.ve_coupled;
}

}  // namespace

Instrument::Instrument(const EngineSettings& settings, const JointVector& start) noexcept
    : settings_(settings), terms_{AxisTerms(settings.translation), AxisTerms(settings.rotation)} {
  for (int a = 0; a < kNumAxes; ++a) chains_[a].reset(settings_.axis(a), start[a]);
  ve_force_delay_.reset(Eigen::Vector3d::Zero());
  position_delay_.reset(start);
  last_position_ = start;
  last_degraded_ = start;
}

void Instrument::apply_settings(const EngineSettings& settings) noexcept {
  for (int a = 0; a < kNumAxes; ++a) {
    chains_[a].on_settings_change(settings_.axis(a), settings.axis(a));
  }
  settings_ = settings;
  terms_ = {AxisTerms(settings_.translation), AxisTerms(settings_.rotation)};
}

void Instrument::resync(const JointVector& q) noexcept {
  for (int a = 0; a < kNumAxes; ++a) chains_[a].resync(settings_.axis(a), q[a]);
  last_position_ = q;
}

inline Instrument::TimePlan Instrument::plan_time(const InstrumentInput& in, const Eigen::Vector3d& ve,
                                                  InstrumentOutput& out) noexcept {
  // A dt below 1/2000 s (or <= 0) advances no time: it is carried into the
  // next update, because a position difference over a microsecond would be
  // a velocity spike.
  double dt = (in.dt_s > 0.0 ? in.dt_s : 0.0) + deferred_dt_s_;
  deferred_dt_s_ = 0.0;
  int substeps = 1;
  if (dt < kMinDt_s) {
    out.status |= kDtDeferred;
    deferred_dt_s_ = dt;
    dt = 0.0;
    if (stalled_updates_ < kMaxStalledUpdates) ++stalled_updates_;
  } else if (dt > kMaxDt_s && dt <= kMaxSubsteps * kMaxDt_s) {
    substeps = static_cast<int>(std::ceil(dt / kMaxDt_s - 1e-9));
    out.status |= kDtSubstepped;
  }
  if (dt > 0.0) {
    stalled_updates_ = 0;
    // Time moves again after a stopped clock: what the stopped updates
    // stretched is dropped. (Not flagged while stopped: a re-anchor drops
    // the time carried, and a fast caller's short dts must add up to move.)
    if (clock_stopped_) needs_resync_ = true;
    clock_stopped_ = false;
  }
  if (needs_resync_ || dt > kMaxSubsteps * kMaxDt_s) {
    if (!anchored_) {
      // First real update: nothing before it happened, not even in the
      // emulated loop's history.
      ve_force_delay_.reset(ve);
      position_delay_.reset(in.position);
      anchored_ = true;
    }
    resync(in.position);
    out.status |= kDtResynced;
    needs_resync_ = false;
    deferred_dt_s_ = 0.0;
    substeps = 1;
    dt = 0.0;
  }
  return {dt, substeps};
}

inline void Instrument::show_degraded(const InstrumentInput& in, const JointVector& degraded, const ToolPose& pose,
                                      const SinCos& pitch, const SinCos& yaw, InstrumentOutput& out) noexcept {
  const LoopEmulation& loop = settings_.loop;
  out.degraded_position =
      position_delay_.step(degraded, in.dt_s, loop.position_latency_s, loop.hold_rate_Hz);
  if (out.degraded_position != in.position) {  // backlash or latency on: the VE sees elsewhere
    // An angle the VE sees unchanged (an axis without backlash) shares the
    // measured one's sine and cosine.
    const JointVector& q_ve = out.degraded_position;
    const ToolPose shown =
        tool_pose(q_ve[kInsertion], same_bits(q_ve[kPitch], in.position[kPitch]) ? pitch : shown_pitch_(q_ve[kPitch]),
                  same_bits(q_ve[kYaw], in.position[kYaw]) ? yaw : shown_yaw_(q_ve[kYaw]));
    out.tip_offset_m = tip_offset(pose, shown);
    out.orientation_offset = orientation_offset(pose, shown);
    out.degraded_tip_m = tip_position(shown);
  } else {
    out.degraded_tip_m = tip_position(pose);
  }
}

InstrumentOutput Instrument::step(const InstrumentInput& in, ButterworthCache& filters) noexcept {
  InstrumentOutput out;
  refreshable_ = false;
  // guard: a non-finite value never reaches a motor
  if (!finite(in.dt_s, in.position, in.ve_force_N)) {
    out.status = kFaultNonFiniteInput;
    out.degraded_position = finite(in.position) ? JointVector(in.position) : last_degraded_;
    needs_resync_ = true;
    return out;
  }

  // F_ve => tip-clipped, delayed/held F_ve => joint forces
  Eigen::Vector3d ve = in.ve_force_N;
  if (settings_.tip_force_saturation.enabled) {
    ve = clip_magnitude(ve, settings_.tip_force_saturation.limit_N);
  }
  const LoopEmulation& loop = settings_.loop;
  ve = ve_force_delay_.step(ve, in.dt_s, loop.force_latency_s, loop.hold_rate_Hz);
  const SinCos pitch = measured_pitch_(in.position[kPitch]);
  const SinCos yaw = measured_yaw_(in.position[kYaw]);
  out.measured_pose = tool_pose(in.position[kInsertion], pitch, yaw);
  const ToolPose& pose = out.measured_pose;
  const JointVector ve_joint = world_to_joint(pose, ve);
  if (!finite(ve_joint)) {
    // A finite VE force so large (near 1e308 N) that its joint components
    // overflow: the chains are not stepped with it.
    internal_fault(in.position, out);
    return out;
  }

  // dt policy: how many sub-steps of which length
  const TimePlan plan = plan_time(in, ve, out);
  if (stalled_updates_ == kMaxStalledUpdates) {
    clock_stopped(in.position, out);
    return out;
  }
  const double dt = plan.dt_s;
  const int substeps = plan.substeps;

  // per DOF chains, sub-stepped along the straight line from the last position
  // (dt/1 is dt: the division is skipped at the usual one sub-step.)
  const double sub_dt = substeps == 1 ? dt : dt / substeps;
  const ButterworthCoefficients filter = sub_dt > 0.0 ? filters.at(sub_dt) : ButterworthCoefficients{};
  JointVector command = JointVector::Zero();
  JointVector degraded = in.position;
  for (int i = 1; i <= substeps; ++i) {
    const bool last = i == substeps;
    const double w = last ? 1.0 : static_cast<double>(i) / substeps;
    for (int a = 0; a < kNumAxes; ++a) {
      // The last sub-step lands exactly on the measured position.
      const double x = last ? in.position[a] : (1.0 - w) * last_position_[a] + w * in.position[a];
      const DofOutput d =
          chains_[a].step(settings_.axis(a), terms_[a == kInsertion ? 0 : 1], x, ve_joint[a], sub_dt, filter);
      command[a] = d.force;
      degraded[a] = d.position;
      keep_fields(d, last_dof_[static_cast<std::size_t>(a)]);
    }
  }
  if (dt > 0.0) last_position_ = in.position;  // a deferred update keeps the start point

  const bool commands_finite = finish_forces(command, out);

  // degraded joints => delayed/held => VE, with display offsets
  show_degraded(in, degraded, pose, pitch, yaw, out);

  if (!commands_finite || !finite(out.displayed_force_N) || !finite(out.degraded_position)) {
    internal_fault(in.position, out);
    return out;
  }
  last_degraded_ = out.degraded_position;
  refreshable_ = loop.force_latency_s == 0.0 && loop.hold_rate_Hz == 0.0;
  return out;
}

void Instrument::internal_fault(const JointVector& q, InstrumentOutput& out) noexcept {
  // Never let it reach a motor; start again from rest at the instrument.
  for (int a = 0; a < kNumAxes; ++a) chains_[a].reset(settings_.axis(a), q[a]);
  last_position_ = q;
  position_delay_.reset(q);  // it may hold the non-finite position
  zero_output(q, out);
  out.status |= kFaultNonFiniteState;
}

void Instrument::clock_stopped(const JointVector& q, InstrumentOutput& out) noexcept {
  // The states are kept as they are (they were not stepped) and dropped
  // when time moves again: the re-anchor of a stall.
  clock_stopped_ = true;
  zero_output(q, out);
  out.status |= kFaultClockStopped;
}

void Instrument::zero_output(const JointVector& q, InstrumentOutput& out) noexcept {
  out.displayed_force_N.setZero();
  out.joint_force.setZero();
  out.degraded_position = q;
  out.degraded_tip_m = tip_position(out.measured_pose);
  out.tip_offset_m.setZero();
  out.orientation_offset.setIdentity();
  last_degraded_ = q;
  refreshable_ = false;
}

inline bool Instrument::finish_forces(JointVector command, InstrumentOutput& out) const noexcept {
  // Checked before the limit, which would turn an infinity into a full-scale
  // command.
  if (!finite(command)) return false;
  // device limit, per axis, last
  out.status &= ~static_cast<std::uint32_t>(kForceLimited);
  for (int a = 0; a < kNumAxes; ++a) {
    const double limit = settings_.device_limit(a);
    if (std::abs(command[a]) > limit) {
      command[a] = saturate(command[a], limit);
      out.status |= kForceLimited;
    }
  }
  out.joint_force = command;
  // joint => world with the same moment arms (eq. 2.19): the displayed force
  // is what the limited motor commands make, so the two outputs never
  // disagree. Below the moment-arm floor the lateral part is smaller than
  // the VE asked for (the torques are L·F, divided by the floor).
  out.displayed_force_N = joint_to_world(out.measured_pose, command, settings_.min_moment_arm_m);
  return true;
}

void Instrument::refresh_forces(const Eigen::Vector3d& ve_force_N, InstrumentOutput& out) noexcept {
  if (!refreshable_) return;
  refreshable_ = false;  // once per step
  if (!finite(ve_force_N)) {
    out.joint_force.setZero();
    out.displayed_force_N.setZero();
    out.status |= kFaultNonFiniteInput;
    needs_resync_ = true;
    return;
  }
  Eigen::Vector3d ve = ve_force_N;
  if (settings_.tip_force_saturation.enabled) {
    ve = clip_magnitude(ve, settings_.tip_force_saturation.limit_N);
  }
  const JointVector ve_joint = world_to_joint(out.measured_pose, ve);
  JointVector command;
  for (int a = 0; a < kNumAxes; ++a) {
    const DofOutput& d = last_dof_[static_cast<std::size_t>(a)];
    command[a] = d.ve_coupled ? d.force
                              : chains_[static_cast<std::size_t>(a)].revise_force(
                                    settings_.axis(a),
                                    (axis_ve_force(settings_.axis(a), ve_joint[a]) + d.model_force) * d.ripple);
  }
  // ve_joint is checked itself: an axis saturation would clip its infinity.
  if (!finite(ve_joint) || !finish_forces(command, out) || !finite(out.displayed_force_N)) {
    // The chains' state came from step() and is finite; only this force is lost.
    out.joint_force.setZero();
    out.displayed_force_N.setZero();
    out.status |= kFaultNonFiniteState;
  }
}

}  // namespace hapticlab
