#pragma once
// A simulated surgeon: moves both instruments of a simulated device (its
// HandAttachment: SimDevice, or the same behind a plugin or the UDP bridge) through a
// task, inside the haptic loop (a LoopAgent).
//
// Traits (per participant, from a seed): speed, force level, hand
// impedance, how much the visual force estimate is off, cue delays, which
// hand is dominant, how consistent trials are, how fast practice pays off.
// Trials vary around the traits and get faster with practice.
//
// The participant never knows the engine setting. Everything a setting
// changes reaches it through the device (what the hand feels) and the VE
// (where the degraded tools are and how much the tissue dents); see hand.h
// for how felt and seen force are combined.

#include <cstdint>

#include "core/device/hand_attachment.h"
#include "core/loop/haptic_loop.h"
#include "core/sim/clip_task.h"
#include "core/sim/dissection_task.h"
#include "core/sim/force_information.h"
#include "core/sim/hand.h"
#include "core/sim/population.h"
#include "core/sim/practice.h"

namespace hapticlab {

struct ParticipantTraits {
  double speed = 1.0;                  // movement time factor (> 1 is slower), ~0.7..1.4
  double force_level = 1.0;            // scales the forces it aims for, ~0.7..1.4
  double consistency = 0.12;           // log-sd of trial-to-trial variation
  double hand_stiffness_N_per_m = 600.0;
  double visual_force_gain = 0.65;     // < 1: forces seen as smaller than they are
  double haptic_delay_s = 0.04;
  double visual_delay_s = 0.16;
  bool right_handed = true;            // the right tool (cautery, clip applier) in the dominant hand
  double nondominant_factor = 1.25;    // the other hand: this much slower and noisier
  double learning_gain = 0.5;          // the first trial takes (1 + gain) times longer...
  double learning_trials = 6.0;        // ...and the excess decays over this many trials
  double visual_noise_log_sd = 0.2;    // slow drift of the visual force estimate (log-sd)
  bool novice = false;                 // force level drawn around the population's novice factor

  // Draws a participant of `population` (validated by the caller); the same
  // seed gives the same person, and the same quantiles of the fitted traits
  // under any population (population.h).
  static ParticipantTraits sample(std::uint64_t seed, const PopulationParams& population = {}) noexcept;
};

struct ParticipantTrial {
  std::uint64_t seed = 0;     // varies this trial's execution
  int practice_trials = 0;    // trials this participant already did (training included)
  // The same trials weighted by their force information, in [0,
  // practice_trials] (practice.h); counts only with learning's
  // force_free_share below 1.
  double force_informed_trials = 0.0;
  LearningModel learning;     // validated by the caller
};

class Participant final : public LoopAgent {
 public:
  // `task` must be the VE the loop steps.
  Participant(const ParticipantTraits& traits, const ParticipantTrial& trial, HandAttachment& device,
              const DissectionTask& task);
  Participant(const ParticipantTraits& traits, const ParticipantTrial& trial, HandAttachment& device,
              const ClipTask& task);

  // Runs the participant's sensorimotor control on its own grid, every
  // kControlPeriod_s (the cue sampling period): at the first loop update at
  // or after each grid point, so 200 Hz on average at any loop rate above
  // it, and every update at slower rates. A person's commands are slow next
  // to the haptic loop. Between control updates the device extrapolates the
  // hand's reference with its velocity, and the hand's spring–damper keeps
  // acting at every device sub-step.
  static constexpr double kControlPeriod_s = CueDelay::kPeriod_s;
  // Within a trial, each press aims at the trial's force with this log-sd:
  // how well a person reproduces a force it feels. The force JND is about
  // 7 % (Pang, Tan & Durlach 1991). Trial to trial the aim varies by the
  // consistency trait.
  static constexpr double kForceReproductionLogSd = 0.07;
  // Forces aimed for in the clip task at a trial force factor of 1 [N]: the
  // applier's seating on the duct, the grasper's lift of it.
  static constexpr double kClipSeatForce_N = 0.3;
  static constexpr double kClipLiftForce_N = 0.25;
  // After pressing the applier through the duct, the next seating aims at
  // this fraction of the force before (no unit): a clear, visible failure
  // is corrected at once, not by the force JND's small steps.
  static constexpr double kGentlerAfterPushThrough = 0.7;
  void act(const LoopTickView& view) noexcept override;

  // The start pose of both instruments: tools retracted in their trocars,
  // pointing at the work area.
  static DeviceJoints start_pose(int instrument) noexcept;

  // For inspection and tests.
  const Hand& hand(int instrument) const noexcept { return hands_[static_cast<std::size_t>(instrument)]; }
  // This trial's factor on every force aimed for (force level times the
  // trial's variation).
  double trial_force_factor() const noexcept { return force_factor_; }
  // The clip applier's seating force over its first (kGentlerAfterPushThrough
  // per push through the duct so far, 1 before any).
  double seat_force_scale() const noexcept { return seat_force_scale_; }
  int phase(int instrument) const noexcept { return static_cast<int>(phase_[static_cast<std::size_t>(instrument)]); }
  // The force information of the trial so far, both instruments, every
  // loop update (force_information.h): what this trial adds to the
  // participant's force-informed practice.
  double force_information() const noexcept { return force_information_.value(); }

 private:
  enum class Phase : std::uint8_t { kApproach, kDescend, kWork, kRelease, kRetract, kDone };

  // Exactly one of the tasks is set.
  Participant(const ParticipantTraits& traits, const ParticipantTrial& trial, HandAttachment& device,
              const DissectionTask* dissection, const ClipTask* clip);

  void act_dissection(double t_s) noexcept;
  void act_clip(double t_s) noexcept;
  // Each hand's phases in a task, always inlined into act_dissection and
  // act_clip (each runs once per simulated update). `done`: the task was
  // complete at the update's start; `marker_x_m`: where the clip being
  // applied goes, as it was at the update's start.
  [[gnu::always_inline]] void dissection_cautery(double t_s, bool done) noexcept;
  [[gnu::always_inline]] void dissection_grasper(double t_s, bool done) noexcept;
  [[gnu::always_inline]] void clip_grasper(double t_s, bool done, double marker_x_m) noexcept;
  [[gnu::always_inline]] void clip_applier(double t_s, bool done, double marker_x_m) noexcept;
  double reach_time(int hand, const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                    double width_m) const noexcept;
  double seen_depth(int hand, const Eigen::Vector3d& tip) const noexcept;
  // Phase steps both tasks share; each returns true once the hand is there.
  // release: stop pressing and lift by lift_m, opening the grip over
  // open_grip_s (kNoGripChange: leave it); retract: withdraw to 12 mm inside
  // the trocar.
  static constexpr double kNoGripChange = -1.0;
  bool release(int hand, double t_s, bool entering, double lift_m, double open_grip_s) noexcept;
  bool retract(int hand, double t_s, bool entering) noexcept;

  ParticipantTraits traits_;
  HandAttachment& device_;
  const DissectionTask* dissection_ = nullptr;
  const ClipTask* clip_ = nullptr;
  Random rng_;
  std::array<Hand, 2> hands_;
  std::array<double, 2> time_factor_{1.0, 1.0};  // this trial's movement-time factor per hand
  double force_factor_ = 1.0;
  std::array<Phase, 2> phase_{Phase::kApproach, Phase::kApproach};
  std::array<double, 2> phase_start_s_{-1.0, -1.0};  // < 0: the phase is not entered yet
  std::array<Eigen::Vector3d, 2> tip_{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  // dissection
  int burn_index_ = -1;         // position in line_path() being exposed
  double removed_seen_at_s_ = -1.0;
  double burn_progress_s_ = 0.0;  // when the cautery last made visible progress
  Eigen::Vector3d grasp_site_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d pull_dir_ = Eigen::Vector3d::UnitZ();
  // clip
  int clip_index_ = 0;
  int clips_seen_missed_ = 0;
  double seat_force_scale_ = 1.0;  // kGentlerAfterPushThrough per push-through so far
  bool started_ = false;
  double last_control_s_ = 0.0;  // loop time of the last control update
  ControlGrid control_{kControlPeriod_s};
  ForceInformation force_information_;
};

}  // namespace hapticlab
