#pragma once
// One simulated hand on one instrument: how a participant moves a tool and
// regulates the force it applies.
//
// - Reaching: minimum-jerk paths (Flash & Hogan 1985) of the tool tip in the
//   world frame, with Fitts-law durations chosen by the caller.
// - Impedance: the hand holds the handle through a spring–damper to its
//   reference (HandCoupling, hand_attachment.h); the tip stiffness is converted to
//   joint stiffnesses through the instrument's lever (K·L² for pitch).
// - Impedance adaptation: against felt forces it cannot predict (ripple,
//   stick-slip) the arm co-contracts, up to four times stiffer
//   (kMaxStiffening in hand.cc, from docs/simulation.md).
// - Force regulation: while pressing along a direction, the hand shifts its
//   reference by an offset that integrates the error between the target
//   force and its estimate of the applied force. The estimate fuses two
//   delayed cues: the force felt through the handle (haptic, ~40 ms) and the
//   force inferred from the visible tissue indentation (visual, ~160 ms,
//   biased and noisy). The weight of the felt cue follows how well felt and
//   seen forces have agreed so far, so without force feedback the hand falls
//   back to vision: slower, biased corrections and harder, more variable
//   pressing — with no knowledge of the setting.

#include <array>

#include <Eigen/Core>

#include "core/common/random.h"
#include "core/device/hand_attachment.h"
#include "core/engine/joint_transform.h"
#include "core/sim/control_grid.h"

namespace hapticlab {

struct HandParams {
  double stiffness_N_per_m = 600.0;   // tip impedance of the arm holding the tool
  double damping_ratio = 0.8;
  double mass_kg = 0.3;               // arm mass, referred to the tip
  double haptic_delay_s = 0.04;
  double visual_delay_s = 0.16;
  double visual_force_gain = 0.75;    // seen/true force: indentation is underestimated
  double regulation_time_s = 0.15;    // time constant of the force correction
  double motor_noise_m = 0.0003;      // sd of slow positional tremor/drift
  double visual_noise = 0.2;          // log-sd of the slowly varying visual force estimate
  double visual_servo_time_s = 0.35;  // time constant of steering the seen tip onto the aim
};

// A fixed-size delay line sampled on a 5 ms grid: the value of a cue as the
// brain gets it some 40–300 ms later. A slot holds the latest value pushed
// in it and advances at the first push at or after each grid point. No
// allocation.
class CueDelay {
 public:
  static constexpr double kPeriod_s = 0.005;
  static constexpr int kSize = 128;  // up to 0.64 s of history
  void reset(double value) noexcept;
  void push(double t_s, double value) noexcept;
  double delayed(double delay_s) const noexcept;

 private:
  std::array<double, kSize> values_{};
  int head_ = 0;
  ControlGrid slots_{kPeriod_s};
};

class Hand {
 public:
  void init(int instrument, const HandParams& params, const Eigen::Vector3d& start_tip_m,
            std::uint64_t seed) noexcept;

  // --- intents (called by the task strategy)
  // Minimum-jerk move of the base reference to `target_m` over duration_s.
  void reach(const Eigen::Vector3d& target_m, double t_s, double duration_s) noexcept;
  // Start pressing along unit `into` with target_force_N against something
  // the participant knows (from training) to be about `stiffness_N_per_m`
  // stiff: the reference offset starts where that force is expected with
  // hand and tissue in series, and the visual force estimate uses it.
  void press(const Eigen::Vector3d& into, double target_force_N, double stiffness_N_per_m) noexcept;
  void set_target_force(double target_force_N) noexcept { target_force_N_ = target_force_N; }
  void stop_press() noexcept { pressing_ = false; }
  void grip_to(double angle_rad, double t_s, double duration_s) noexcept;

  bool reach_done(double t_s) const noexcept { return t_s >= reach_end_s_; }
  bool grip_done(double t_s) const noexcept { return t_s >= grip_end_s_; }
  bool pressing() const noexcept { return pressing_; }
  const Eigen::Vector3d& base() const noexcept { return base_m_; }
  double estimated_force_N() const noexcept { return estimate_N_; }
  double target_force_N() const noexcept { return target_force_N_; }
  double haptic_weight() const noexcept { return haptic_weight_; }
  double press_offset_m() const noexcept { return offset_m_; }
  // Indentation as the participant currently sees it (visual delay applied) [m].
  double seen_depth_m() const noexcept { return seen_depth_m_; }
  // Distance between the aim and the tip as seen (delayed), across the
  // press direction while pressing [m].
  double aim_error_m() const noexcept { return aim_error_m_; }
  const Eigen::Vector3d& aim_correction_m() const noexcept { return correction_m_; }
  // Present arm stiffness over the relaxed one: > 1 while the hand braces
  // against a force it cannot predict (impedance adaptation).
  double stiffening() const noexcept { return stiffening_; }

  // --- every update
  // Before step(): the force the device's motors put on the handle
  // (SimDevice::motor_force), which the arm braces against when it varies
  // unpredictably (impedance adaptation).
  // `pose` is tool_pose of the device joints (insertion, pitch, yaw), shared
  // by both calls of an update.
  void feel_device(const ToolPose& pose, const DeviceJoints& device_force, double dt_s) noexcept;
  void feel_device(const DeviceJoints& q, const DeviceJoints& device_force, double dt_s) noexcept {
    feel_device(pose_of(q), device_force, dt_s);
  }
  // `q` the instrument's joints as the hand feels them (device), `felt` the
  // force the hand exerts on the handle (SimDevice::hand_force), `seen_depth_m`
  // how far the tool visibly indents the tissue along the press direction.
  // `seen_tip_m` is where the tool tip shows in the VE: the hand steers it
  // onto the aim point visually, which is how a person makes up for
  // backlash, cogging and friction that push the tool off course.
  void step(double t_s, double dt_s, const ToolPose& pose, const DeviceJoints& felt,
            double seen_depth_m, const Eigen::Vector3d& seen_tip_m, HandCouplings& out) noexcept;
  void step(double t_s, double dt_s, const DeviceJoints& q, const DeviceJoints& felt,
            double seen_depth_m, const Eigen::Vector3d& seen_tip_m, HandCouplings& out) noexcept {
    step(t_s, dt_s, pose_of(q), felt, seen_depth_m, seen_tip_m, out);
  }
  static ToolPose pose_of(const DeviceJoints& q) noexcept {
    return tool_pose(JointVector(q[kJointInsertion], q[kJointPitch], q[kJointYaw]));
  }

 private:
  // The stages of step(), in its order, always inlined: step() runs for
  // each hand on every simulated update, and the compiler sees it as the
  // one body it was.
  // The base path: where the reach's minimum-jerk path is at t_s.
  [[gnu::always_inline]] void follow_reach(double t_s) noexcept;
  // Tremor and the visual estimate's drift, at the cue rate.
  [[gnu::always_inline]] void update_slow_noise(double t_s) noexcept;
  // The press: the felt and seen force cues, their agreement, and the
  // offset along the press direction that regulates the force. `k`: the
  // arm's present stiffness [N/m].
  [[gnu::always_inline]] void regulate_force(double t_s, double dt_s, const ToolPose& pose,
                                             const DeviceJoints& felt, double seen_depth_m, double k) noexcept;
  // Visual steering: the seen tip (delayed) pulled onto the aim.
  [[gnu::always_inline]] void steer(double t_s, double dt_s, const Eigen::Vector3d& seen_tip_m) noexcept;

  int instrument_ = 0;
  HandParams params_;
  Random rng_;
  // reaching
  Eigen::Vector3d base_m_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d base_velocity_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d reach_from_m_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d reach_to_m_ = Eigen::Vector3d::Zero();
  double reach_start_s_ = 0.0, reach_end_s_ = 0.0;
  // pressing
  bool pressing_ = false;
  Eigen::Vector3d into_ = -Eigen::Vector3d::UnitZ();
  double target_force_N_ = 0.0;
  double offset_m_ = 0.0;
  double believed_stiffness_N_per_m_ = 220.0;
  double seen_depth_m_ = 0.0;
  double aim_error_m_ = 0.0;
  double estimate_N_ = 0.0;
  double agreement_ = 1.0;     // running felt/seen force ratio
  double haptic_weight_ = 0.9;
  CueDelay felt_cue_, seen_cue_;
  double visual_bias_ = 0.0;   // slowly varying log error of the visual estimate
  double visual_scale_ = 1.0;  // visual_force_gain·exp(visual_bias_), updated with it
  Eigen::Vector3d tremor_m_ = Eigen::Vector3d::Zero();
  std::array<CueDelay, 3> seen_tip_cue_;
  Eigen::Vector3d correction_m_ = Eigen::Vector3d::Zero();  // visual aim correction
  ControlGrid noise_grid_{CueDelay::kPeriod_s};
  // impedance adaptation
  Eigen::Vector3d felt_mean_N_ = Eigen::Vector3d::Zero();
  double disturbance_var_N2_ = 0.0;
  double felt_smooth_N_ = 0.0;  // felt force along the press, averaged (regulation cue)
  double stiffening_ = 1.0;  // arm stiffness / relaxed stiffness, 1..kMaxStiffening
  // grip
  double grip_from_rad_ = 0.3, grip_to_rad_ = 0.3, grip_start_s_ = 0.0, grip_end_s_ = 0.0;
};

}  // namespace hapticlab
