#include "core/sim/hand.h"

#include <algorithm>
#include <cmath>

#include "core/engine/joint_transform.h"
#include "core/loop/workspace.h"

namespace hapticlab {

namespace {

// Grip and twist: the fingers hold the handle stiffly compared to its
// 0.32 N·m peak torque, so a clip's kick moves the jaws a few degrees.
constexpr double kGripStiffness_Nm_per_rad = 0.5;
constexpr double kGripMass_kg_m2 = 2e-5;
constexpr double kTwistStiffness_Nm_per_rad = 0.05;
constexpr double kTwistMass_kg_m2 = 2e-5;
// A press offset left when pressing stops fades with this time constant
// instead of jumping back (which would fling the tool).
constexpr double kOffsetRelease_s = 0.1;
constexpr double kTremorTime_s = 0.2;
constexpr double kVisualDrift_s = 1.0;
constexpr double kAgreementTime_s = 0.5;
constexpr double kMinArm_m = 0.02;
// A gap the eye resolves between tool and tissue on the monitor [m].
constexpr double kVisibleGap_m = 0.0005;
// Largest aim correction a participant makes before re-planning [m].
constexpr double kMaxCorrection_m = 0.008;
// Impedance adaptation (Burdet et al. 2001, Nature 414; Franklin et al.
// 2008): people stiffen the arm by co-contraction against forces they cannot
// predict. The forces of moving the tool's own mass are predicted (internal
// model), so only the device's force counts; the disturbance is its
// deviation from its recent mean (the ripple of cogging, the jerks of stick-slip or backlash); steady
// contact forces do not count. Stiffness rises with its RMS above a
// threshold, up to kMaxStiffening times the relaxed value, over about
// kStiffenTime_s.
// Force regulation works on the felt force averaged over a few hundred ms:
// voluntary force control is slow (~1-2 Hz), ripple above that is felt as
// texture, not as a change of the tissue's push.
constexpr double kFeltSmoothing_s = 0.3;
constexpr double kDisturbanceMeanTime_s = 1.0;
constexpr double kDisturbanceWindow_s = 1.0;
constexpr double kDisturbanceThreshold_N = 0.04;
constexpr double kDisturbancePerStiffening_N = 0.08;
constexpr double kMaxStiffening = 4.0;
constexpr double kStiffenTime_s = 0.3;

double min_jerk(double tau) noexcept { return tau * tau * tau * (10.0 + tau * (-15.0 + 6.0 * tau)); }
double min_jerk_rate(double tau) noexcept { return 30.0 * tau * tau * (1.0 - tau) * (1.0 - tau); }

HandCoupling coupling(double x, double v, double k, double zeta, double m_total, double m_hand) noexcept {
  return {x, v, k, 2.0 * zeta * std::sqrt(k * m_total), 0.0, m_hand};
}

}  // namespace

void CueDelay::reset(double value) noexcept {
  values_.fill(value);
  head_ = 0;
}

void CueDelay::push(double t_s, double value) noexcept {
  if (!slots_.due(t_s)) {
    values_[static_cast<std::size_t>(head_)] = value;  // latest value of the current slot
    return;
  }
  head_ = (head_ + 1) % kSize;
  values_[static_cast<std::size_t>(head_)] = value;
  slots_.advance(t_s);
}

double CueDelay::delayed(double delay_s) const noexcept {
  int back = static_cast<int>(std::lround(delay_s / kPeriod_s));
  back = std::clamp(back, 0, kSize - 1);
  return values_[static_cast<std::size_t>((head_ - back + kSize) % kSize)];
}

void Hand::init(int instrument, const HandParams& params, const Eigen::Vector3d& start_tip_m,
                std::uint64_t seed) noexcept {
  instrument_ = instrument;
  params_ = params;
  rng_.reseed(seed);
  base_m_ = reach_from_m_ = reach_to_m_ = start_tip_m;
  base_velocity_.setZero();
  reach_start_s_ = reach_end_s_ = 0.0;
  pressing_ = false;
  offset_m_ = 0.0;
  estimate_N_ = 0.0;
  agreement_ = 1.0;  // trained with force feedback: expects to feel what it sees
  haptic_weight_ = 0.9;
  felt_cue_.reset(0.0);
  seen_cue_.reset(0.0);
  for (int k = 0; k < 3; ++k) seen_tip_cue_[static_cast<std::size_t>(k)].reset(start_tip_m[k]);
  visual_bias_ = params_.visual_noise * rng_.normal();
  visual_scale_ = params_.visual_force_gain * std::exp(visual_bias_);
  tremor_m_.setZero();
  noise_grid_ = ControlGrid(CueDelay::kPeriod_s);
  correction_m_.setZero();
  felt_mean_N_.setZero();
  felt_smooth_N_ = 0.0;
  disturbance_var_N2_ = 0.0;
  stiffening_ = 1.0;
  grip_from_rad_ = grip_to_rad_ = 0.3;
  grip_start_s_ = grip_end_s_ = 0.0;
}

void Hand::reach(const Eigen::Vector3d& target_m, double t_s, double duration_s) noexcept {
  reach_from_m_ = base_m_;
  reach_to_m_ = target_m;
  reach_start_s_ = t_s;
  reach_end_s_ = t_s + std::max(duration_s, 0.05);
}

void Hand::press(const Eigen::Vector3d& into, double target_force_N, double stiffness_N_per_m) noexcept {
  into_ = into.normalized();
  believed_stiffness_N_per_m_ = stiffness_N_per_m;
  target_force_N_ = target_force_N;
  if (!pressing_) {
    // Hand and tissue in series, as learned with force feedback.
    offset_m_ = target_force_N *
                (1.0 / (params_.stiffness_N_per_m * stiffening_) + 1.0 / believed_stiffness_N_per_m_);
  }
  pressing_ = true;
}

void Hand::grip_to(double angle_rad, double t_s, double duration_s) noexcept {
  grip_from_rad_ = grip_to_rad_;
  grip_to_rad_ = angle_rad;
  grip_start_s_ = t_s;
  grip_end_s_ = t_s + std::max(duration_s, 0.02);
}

void Hand::feel_device(const ToolPose& pose, const DeviceJoints& device_force, double dt_s) noexcept {
  const JointVector f(device_force[kJointInsertion], device_force[kJointPitch], device_force[kJointYaw]);
  const Eigen::Vector3d tip_N = joint_to_world(pose, f, kMinArm_m);
  felt_mean_N_ += std::min(1.0, dt_s / kDisturbanceMeanTime_s) * (tip_N - felt_mean_N_);
  const double deviation2 = (tip_N - felt_mean_N_).squaredNorm();
  disturbance_var_N2_ += std::min(1.0, dt_s / kDisturbanceWindow_s) * (deviation2 - disturbance_var_N2_);
  const double excess_N = std::max(0.0, std::sqrt(disturbance_var_N2_) - kDisturbanceThreshold_N);
  const double wanted = 1.0 + std::min(kMaxStiffening - 1.0, excess_N / kDisturbancePerStiffening_N);
  stiffening_ += std::min(1.0, dt_s / kStiffenTime_s) * (wanted - stiffening_);
}

inline void Hand::follow_reach(double t_s) noexcept {
  if (t_s >= reach_end_s_) {
    base_m_ = reach_to_m_;
    base_velocity_.setZero();
  } else {
    const double span = reach_end_s_ - reach_start_s_;
    const double tau = std::clamp((t_s - reach_start_s_) / span, 0.0, 1.0);
    base_m_ = reach_from_m_ + min_jerk(tau) * (reach_to_m_ - reach_from_m_);
    base_velocity_ = (min_jerk_rate(tau) / span) * (reach_to_m_ - reach_from_m_);
  }
}

// Slow noise: tremor/drift of the hand and drift of the visual estimate,
// updated at the cue rate (200 Hz) since they are slow anyway.
inline void Hand::update_slow_noise(double t_s) noexcept {
  if (!noise_grid_.due(t_s)) return;
  noise_grid_.advance(t_s);
  const double h_s = noise_grid_.period_s();
  const double a = std::min(1.0, h_s / kTremorTime_s);
  const double s = params_.motor_noise_m * std::sqrt(2.0 * a);
  for (int k = 0; k < 3; ++k) tremor_m_[k] += -a * tremor_m_[k] + s * rng_.normal();
  const double b = std::min(1.0, h_s / kVisualDrift_s);
  visual_bias_ += -b * visual_bias_ + params_.visual_noise * std::sqrt(2.0 * b) * rng_.normal();
  visual_scale_ = params_.visual_force_gain * std::exp(visual_bias_);
}

inline void Hand::regulate_force(double t_s, double dt_s, const ToolPose& pose, const DeviceJoints& felt,
                                 double seen_depth_m, double k) noexcept {
  if (!pressing_) {
    felt_smooth_N_ = 0.0;
    felt_cue_.push(t_s, 0.0);
    seen_cue_.push(t_s, seen_depth_m);
    seen_depth_m_ = seen_cue_.delayed(params_.visual_delay_s);
    offset_m_ -= offset_m_ * std::min(1.0, dt_s / kOffsetRelease_s);
    return;
  }
  const JointVector reaction(-felt[kJointInsertion], -felt[kJointPitch], -felt[kJointYaw]);
  const Eigen::Vector3d felt_tip = joint_to_world(pose, reaction, kMinArm_m);
  const double felt_N = std::max(0.0, -into_.dot(felt_tip));
  felt_smooth_N_ += std::min(1.0, dt_s / kFeltSmoothing_s) * (felt_N - felt_smooth_N_);
  felt_cue_.push(t_s, felt_smooth_N_);
  seen_cue_.push(t_s, seen_depth_m);
  const double h = felt_cue_.delayed(params_.haptic_delay_s);
  const double seen_depth = seen_cue_.delayed(params_.visual_delay_s);
  seen_depth_m_ = seen_depth;
  const double v = seen_depth > 0.0 ? visual_scale_ *
                                          believed_stiffness_N_per_m_ * seen_depth
                                    : 0.0;
  if (v > 0.1) {
    const double ratio = std::clamp(h / v, 0.0, 1.5);
    agreement_ += (ratio - agreement_) * std::min(1.0, dt_s / kAgreementTime_s);
  }
  const double h_contact = h;
  const double trust = std::clamp(agreement_, 0.0, 1.0);
  haptic_weight_ = 0.9 * trust * trust;
  // A visible gap between tool and tissue is unmistakable: whatever the
  // hand feels then (friction, cogging, inertia) is not contact force.
  estimate_N_ = seen_depth < -kVisibleGap_m ? 0.0 : haptic_weight_ * h_contact + (1.0 - haptic_weight_) * v;
  // Divided by the present stiffness: the force correction keeps its pace
  // however stiff the arm is.
  offset_m_ += dt_s * (target_force_N_ - estimate_N_) / (k * params_.regulation_time_s);
  offset_m_ = std::clamp(offset_m_, -0.004, 0.020);
}

// Once a reach is over, the seen tip (delayed) is pulled onto the aim.
// Along the press direction the force regulation rules.
inline void Hand::steer(double t_s, double dt_s, const Eigen::Vector3d& seen_tip_m) noexcept {
  for (int k = 0; k < 3; ++k) seen_tip_cue_[static_cast<std::size_t>(k)].push(t_s, seen_tip_m[k]);
  const Eigen::Vector3d seen(seen_tip_cue_[0].delayed(params_.visual_delay_s),
                             seen_tip_cue_[1].delayed(params_.visual_delay_s),
                             seen_tip_cue_[2].delayed(params_.visual_delay_s));
  Eigen::Vector3d error = reach_to_m_ - seen;
  if (pressing_) error -= error.dot(into_) * into_;
  aim_error_m_ = error.norm();
  if (t_s >= reach_end_s_) {
    // Errors below what the eye resolves are left alone.
    if (error.norm() > kVisibleGap_m) {
      correction_m_ += std::min(1.0, dt_s / params_.visual_servo_time_s) * error;
      const double n = correction_m_.norm();
      if (n > kMaxCorrection_m) correction_m_ *= kMaxCorrection_m / n;
    }
  }
}

void Hand::step(double t_s, double dt_s, const ToolPose& pose, const DeviceJoints& felt,
                double seen_depth_m, const Eigen::Vector3d& seen_tip_m, HandCouplings& out) noexcept {
  // Base path (minimum jerk), slow noise, the force cues and the press,
  // visual steering; then the couplings to the reference pose.
  follow_reach(t_s);
  update_slow_noise(t_s);
  const double k = params_.stiffness_N_per_m * stiffening_;
  regulate_force(t_s, dt_s, pose, felt, seen_depth_m, k);
  steer(t_s, dt_s, seen_tip_m);

  const Eigen::Vector3d p_ref = base_m_ + correction_m_ + offset_m_ * into_ + tremor_m_;
  const Eigen::Vector3d p = p_ref - kTrocarPosition_m[static_cast<std::size_t>(instrument_)];
  const JointVector q_ref = joints_for_tip(instrument_, p_ref);
  const double L = std::max(q_ref[0], kMinArm_m);
  const double cos_pitch = std::cos(q_ref[1]);
  const Eigen::Vector3d& v = base_velocity_;
  const double L_rate = p.dot(v) / L;
  const double pitch_rate = (v.y() * L - p.y() * L_rate) / (L * L * std::max(cos_pitch, 0.1));
  const double xz2 = std::max(p.x() * p.x() + p.z() * p.z(), 1e-6);
  const double yaw_rate = (-v.x() * p.z() + p.x() * v.z()) / xz2;

  const double m = params_.mass_kg, z = params_.damping_ratio;
  const double arm_p2 = L * L, arm_y2 = (L * cos_pitch) * (L * cos_pitch);
  // Total moving mass for the damping: hand plus the device's own carriage.
  out[kJointInsertion] = coupling(q_ref[0], L_rate, k, z, m + 0.05, m);
  out[kJointPitch] = coupling(q_ref[1], pitch_rate, k * arm_p2, z, m * arm_p2 + 2e-4, m * arm_p2);
  out[kJointYaw] = coupling(q_ref[2], yaw_rate, k * arm_y2, z, m * arm_y2 + 2e-4, m * arm_y2);
  out[kJointTwist] = coupling(0.0, 0.0, kTwistStiffness_Nm_per_rad, 0.8, 2.0 * kTwistMass_kg_m2, kTwistMass_kg_m2);

  double grip = grip_to_rad_, grip_rate = 0.0;
  if (t_s < grip_end_s_) {
    const double span = grip_end_s_ - grip_start_s_;
    const double tau = std::clamp((t_s - grip_start_s_) / span, 0.0, 1.0);
    grip = grip_from_rad_ + tau * (grip_to_rad_ - grip_from_rad_);
    grip_rate = (grip_to_rad_ - grip_from_rad_) / span;
  }
  out[kJointGrip] = coupling(grip, grip_rate, kGripStiffness_Nm_per_rad, 0.8, 2.0 * kGripMass_kg_m2, kGripMass_kg_m2);
}

}  // namespace hapticlab
