#include "core/sim/participant.h"

#include <algorithm>
#include <cmath>

#include "core/engine/status.h"
#include "core/loop/workspace.h"

namespace hapticlab {

namespace {

constexpr int kLeft = 0, kRight = 1;
constexpr double kGripOpenTarget_rad = 0.30;
constexpr double kGripShut_rad = 0.0;

// Forces the participant aims for at force_level 1 [N]: light cautery
// contact, a firm pull on the tissue, light seating of the clip applier and a
// gentle lift of the grasped duct — all below the 1 N the thesis' clip
// forces rarely exceeded.
constexpr double kCauteryForce_N = 0.45;
constexpr double kTouchForce_N = 0.15;
constexpr double kTensionForce_N = 0.6;
constexpr double kSeatForce_N = Participant::kClipSeatForce_N;
constexpr double kLiftForce_N = Participant::kClipLiftForce_N;

// Fitts' law for laparoscopic reaching, T = a + b·log2(D/W + 1).
constexpr double kFittsA_s = 0.20;
constexpr double kFittsB_s = 0.14;
// Dragging the cautery along the line while burning [m/s].
constexpr double kDragSpeed_m_per_s = 0.006;

}  // namespace

ParticipantTraits ParticipantTraits::sample(std::uint64_t seed, const PopulationParams& population) noexcept {
  Random r = Random::derive(seed, 0x747261697473ull);
  ParticipantTraits t;
  t.speed = std::clamp(r.lognormal_factor(0.2), 0.65, 1.5);
  // Drawn now, placed once novice is known (the last draw, so that a
  // population without novices draws everything else the same).
  const double u_force = r.uniform();
  // The fitted traits (population.h): trial-to-trial consistency, the
  // visual force gain, the force level.
  t.consistency = draw_consistency(r.uniform(), population);
  // Arm endpoint stiffness with the co-contraction of precise work
  // (several hundred N/m up to ~1 kN/m).
  t.hand_stiffness_N_per_m = r.uniform(450.0, 800.0);
  t.visual_force_gain = draw_visual_gain(r.uniform(), population);
  t.haptic_delay_s = r.uniform(0.03, 0.06);
  t.visual_delay_s = r.uniform(0.13, 0.20);
  t.right_handed = r.uniform() >= 0.1;
  t.nondominant_factor = r.uniform(1.1, 1.4);
  t.learning_gain = r.uniform(0.3, 0.7);
  t.learning_trials = r.uniform(4.0, 10.0);
  t.visual_noise_log_sd = population.visual_noise_log_sd;
  t.novice = r.uniform() < population.novice_share;
  t.force_level = draw_force_level(u_force, t.novice, population);
  return t;
}

DeviceJoints Participant::start_pose(int instrument) noexcept {
  const JointVector aim = joints_for_tip(instrument, Eigen::Vector3d(0.0, 0.0, -0.11));
  return {0.005, aim[1], aim[2], 0.0, kGripOpenTarget_rad};
}

Participant::Participant(const ParticipantTraits& traits, const ParticipantTrial& trial, HandAttachment& device,
                         const DissectionTask& task)
    : Participant(traits, trial, device, &task, nullptr) {}

Participant::Participant(const ParticipantTraits& traits, const ParticipantTrial& trial, HandAttachment& device,
                         const ClipTask& task)
    : Participant(traits, trial, device, nullptr, &task) {}

Participant::Participant(const ParticipantTraits& traits, const ParticipantTrial& trial, HandAttachment& device,
                         const DissectionTask* dissection, const ClipTask* clip)
    : traits_(traits), device_(device), dissection_(dissection), clip_(clip),
      rng_(Random::derive(trial.seed, 0x747269616cull)) {

  const double practiced =
      effective_practice_trials({trial.practice_trials, trial.force_informed_trials}, trial.learning);
  const double practice = 1.0 + traits_.learning_gain * std::exp(-practiced / traits_.learning_trials);
  const double trial_speed = rng_.lognormal_factor(traits_.consistency);
  force_factor_ = traits_.force_level * rng_.lognormal_factor(traits_.consistency);
  const int dominant = traits_.right_handed ? kRight : kLeft;
  for (int h = 0; h < 2; ++h) {
    const double other = h == dominant ? 1.0 : traits_.nondominant_factor;
    time_factor_[static_cast<std::size_t>(h)] = traits_.speed * practice * trial_speed * other;
  }
}

double Participant::reach_time(int hand, const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                               double width_m) const noexcept {
  const double d = (to - from).norm();
  return (kFittsA_s + kFittsB_s * std::log2(d / width_m + 1.0)) * time_factor_[static_cast<std::size_t>(hand)];
}

bool Participant::release(int h, double t, bool entering, double lift_m,
                          double open_grip_s) noexcept {
  Hand& hand = hands_[static_cast<std::size_t>(h)];
  const bool opens_grip = open_grip_s > 0.0;
  if (entering) {
    hand.stop_press();
    if (opens_grip) hand.grip_to(kGripOpenTarget_rad, t, open_grip_s);
    hand.reach(hand.base() + Eigen::Vector3d(0, 0, lift_m), t,
               0.3 * time_factor_[static_cast<std::size_t>(h)]);
    return false;
  }
  return hand.reach_done(t) && (!opens_grip || hand.grip_done(t));
}

bool Participant::retract(int h, double t, bool entering) noexcept {
  Hand& hand = hands_[static_cast<std::size_t>(h)];
  if (entering) {
    const Eigen::Vector3d& trocar = kTrocarPosition_m[static_cast<std::size_t>(h)];
    const Eigen::Vector3d out = trocar + 0.012 * (hand.base() - trocar).normalized();
    hand.stop_press();
    hand.reach(out, t, reach_time(h, hand.base(), out, 0.01));
    return false;
  }
  return hand.reach_done(t);
}

double Participant::seen_depth(int hand, const Eigen::Vector3d& tip) const noexcept {
  if (dissection_ != nullptr) {
    const auto& g = dissection_->grasp();
    if (hand == kLeft && g.holding()) return (tip - g.anchor()).dot(pull_dir_);
    const int cell = dissection_->cell_at(tip.x(), tip.y());
    const bool covered = cell >= 0 && !dissection_->removed(cell);
    const double z = dissection_->params().surface_z_m - (covered ? 0.0 : 0.002);
    return z - tip.z();
  }
  const auto& g = clip_->grasp();
  if (hand == kLeft && g.holding()) return (tip - g.anchor()).z();
  // The deeper of the two surfaces the tool can be seen to press: the duct
  // wall, or the structures below it once the tool has gone past the duct.
  // (Seeing only the duct, a tool pressing the structures read as a visible
  // gap, so the hand took the force it felt for no contact and pressed on.)
  const ClipParams& p = clip_->params();
  const Eigen::Vector3d radial(0.0, tip.y() - clip_->duct_y_m(), tip.z() - p.duct_z_m);
  const double duct_m = std::abs(tip.x()) <= p.duct_half_length_m ? p.duct_radius_m - radial.norm() : -1.0;
  return std::max(duct_m, p.base_z_m - tip.z());
}

void Participant::act(const LoopTickView& view) noexcept {
  for (std::size_t i = 0; i < 2; ++i) force_information_.add(view.engine[i].displayed_force_N, view.ve.tip_force_N[i]);
  const double t = view.t_s;
  if (!control_.due(t)) return;  // the grid starts at 0, so the first update is always due
  control_.advance(t);
  const double dt_s = started_ ? t - last_control_s_ : view.dt_s;
  last_control_s_ = t;
  tip_ = view.ve_input.tip_m;
  if (!started_) {
    started_ = true;
    const int dominant = traits_.right_handed ? kRight : kLeft;
    for (int h = 0; h < 2; ++h) {
      HandParams p;
      const double other = h == dominant ? 1.0 : traits_.nondominant_factor;
      p.stiffness_N_per_m = traits_.hand_stiffness_N_per_m / other;
      p.haptic_delay_s = traits_.haptic_delay_s;
      p.visual_delay_s = traits_.visual_delay_s;
      p.visual_force_gain = traits_.visual_force_gain;
      p.visual_noise = traits_.visual_noise_log_sd;
      p.motor_noise_m = 0.0003 * other;
      p.regulation_time_s = 0.15 * other;
      hands_[static_cast<std::size_t>(h)].init(h, p, tip_[static_cast<std::size_t>(h)], rng_.next_u64());
      hands_[static_cast<std::size_t>(h)].grip_to(kGripOpenTarget_rad, t, 0.05);
      // Not yet entered: the first phase issues its intent on this update.
      // (Marking it entered here left the first reach unset: the left hand
      // went for the world origin between the trocars, yaw into its end stop.)
      phase_start_s_[static_cast<std::size_t>(h)] = -1.0;
    }
  }

  if (dissection_ != nullptr) act_dissection(t);
  else act_clip(t);

  for (int i = 0; i < 2; ++i) {
    const auto ui = static_cast<std::size_t>(i);
    HandCouplings couplings;
    // The engine has already built the pose of this reading; recomputing it
    // was ~3 % of a simulated update.
    const InstrumentOutput& engine = view.engine[ui];
    const ToolPose pose = (engine.status & (kFaultNonFiniteInput | kFaultInvalidArgument)) == 0
                              ? engine.measured_pose
                              : Hand::pose_of(view.reading.position[ui]);
    hands_[ui].feel_device(pose, device_.motor_force(i), dt_s);
    hands_[ui].step(t, dt_s, pose, device_.hand_force(i),
                    seen_depth(i, tip_[ui]), tip_[ui], couplings);
    device_.set_hand(i, couplings);
  }
}

// Phase bookkeeping shared by both tasks: `entering` is true on the first
// update of a phase, so each intent is issued once.
#define HL_ENTER(h, p)                              \
  do {                                              \
    phase_[static_cast<std::size_t>(h)] = (p);      \
    phase_start_s_[static_cast<std::size_t>(h)] = -1.0; \
  } while (0)

namespace {

// The index on the task's line path of the first cell at or after `from`
// not yet removed, -1 when none is left.
int next_uncut(const DissectionTask& task, int from) noexcept {
  const auto& path = task.line_path();
  for (int k = std::max(from, 0); k < static_cast<int>(path.size()); ++k)
    if (!task.removed(path[static_cast<std::size_t>(k)])) return k;
  return -1;
}

}  // namespace

// --- right hand: the cautery
inline void Participant::dissection_cautery(double t, bool done) noexcept {
  const DissectionTask& task = *dissection_;
  const auto& path = task.line_path();
  const auto next_line_index = [&task](int from) { return next_uncut(task, from); };
  const double cautery_N = kCauteryForce_N * force_factor_;
  Hand& hand = hands_[kRight];
  const bool entering = phase_start_s_[kRight] < 0.0;
  if (entering) phase_start_s_[kRight] = t;
  switch (phase_[kRight]) {
    case Phase::kApproach:
      if (entering || burn_index_ < 0) {
        burn_index_ = next_line_index(0);
        if (burn_index_ < 0) { HL_ENTER(kRight, Phase::kRetract); break; }
        const Eigen::Vector3d hover =
            task.cell_center(path[static_cast<std::size_t>(burn_index_)]) + Eigen::Vector3d(0, 0, 0.004);
        hand.reach(hover, t, reach_time(kRight, hand.base(), hover, 0.002));
      } else if (hand.reach_done(t)) {
        HL_ENTER(kRight, Phase::kDescend);
      }
      break;
    case Phase::kDescend:
      if (entering) {
        const Eigen::Vector3d spot = task.cell_center(path[static_cast<std::size_t>(burn_index_)]);
        hand.reach(spot, t, 0.35 * time_factor_[kRight]);
        hand.press(-Eigen::Vector3d::UnitZ(), cautery_N * rng_.lognormal_factor(kForceReproductionLogSd),
                   task.params().tissue.stiffness_N_per_m);
      } else if (hand.reach_done(t)) {
        HL_ENTER(kRight, Phase::kWork);
        removed_seen_at_s_ = -1.0;
        burn_progress_s_ = t;
      }
      break;
    case Phase::kWork: {
      if (done) { HL_ENTER(kRight, Phase::kRelease); break; }
      const int cell = path[static_cast<std::size_t>(burn_index_)];
      if (!task.removed(cell)) {
        // No visible progress: press a little harder, within reason. The
        // bound is three times the person's own force, but never below
        // three times the average person's: a light hand that feels a
        // device's force (a cogging detent, friction) as the tissue's, and
        // sees nothing burn, presses on like anyone else rather than
        // holding the tool off the tissue until the time limit.
        if (t - burn_progress_s_ > 1.0 * time_factor_[kRight]) {
          burn_progress_s_ = t;
          const double bound_N = 3.0 * kCauteryForce_N * std::max(force_factor_, 1.0);
          hand.set_target_force(std::min(bound_N, hand.target_force_N() * 1.15));
        }
        break;
      }
      burn_progress_s_ = t;
      // The participant sees the tissue go only after the visual delay.
      if (removed_seen_at_s_ < 0.0) removed_seen_at_s_ = t;
      if (t - removed_seen_at_s_ < traits_.visual_delay_s) break;
      removed_seen_at_s_ = -1.0;
      const int next = next_line_index(burn_index_ + 1);
      if (next < 0) { HL_ENTER(kRight, Phase::kRelease); break; }
      burn_index_ = next;
      const Eigen::Vector3d spot = task.cell_center(path[static_cast<std::size_t>(next)]);
      const double dist = (spot - hand.base()).norm();
      if (dist > 0.005) { HL_ENTER(kRight, Phase::kRelease); break; }
      hand.reach(spot, t, std::max(0.12, dist / kDragSpeed_m_per_s) * time_factor_[kRight]);
      if (rng_.uniform() < 0.15)  // now and then the surgeon re-sets the pressure
        hand.set_target_force(cautery_N * rng_.lognormal_factor(kForceReproductionLogSd));
      break;
    }
    case Phase::kRelease:
      if (release(kRight, t, entering, 0.005, kNoGripChange)) {
        if (done) { HL_ENTER(kRight, Phase::kRetract); }
        else { burn_index_ = -1; HL_ENTER(kRight, Phase::kApproach); }
      }
      break;
    case Phase::kRetract:
      if (retract(kRight, t, entering)) HL_ENTER(kRight, Phase::kDone);
      break;
    case Phase::kDone:
      break;
  }
}

// --- left hand: the grasper that tensions the tissue near the cautery
inline void Participant::dissection_grasper(double t, bool done) noexcept {
  const DissectionTask& task = *dissection_;
  const auto& path = task.line_path();
  Hand& hand = hands_[kLeft];
  const bool entering = phase_start_s_[kLeft] < 0.0;
  if (entering) phase_start_s_[kLeft] = t;
  const Eigen::Vector3d target =
      burn_index_ >= 0 ? task.cell_center(path[static_cast<std::size_t>(burn_index_)]) : hands_[kRight].base();
  const double tension_N = kTensionForce_N * force_factor_;
  const auto& grasp = task.grasp();
  switch (phase_[kLeft]) {
    case Phase::kApproach:
      if (done) { HL_ENTER(kLeft, Phase::kRetract); break; }
      if (entering) {
        // Grasp beside and behind the dissection site, pulling away from it.
        const double side = target.y() > 0.0 ? -1.0 : 1.0;
        const auto& p = task.params();
        grasp_site_ = Eigen::Vector3d(
            std::clamp(target.x() + 0.004, -p.half_width_x_m + 0.001, p.half_width_x_m - 0.001),
            std::clamp(target.y() + side * 0.006, -p.half_width_y_m + 0.001, p.half_width_y_m - 0.001),
            p.surface_z_m);
        Eigen::Vector3d away = grasp_site_ - target;
        away.z() = 0.0;
        if (away.norm() < 1e-6) away = Eigen::Vector3d(-1, 0, 0);
        pull_dir_ = (away.normalized() + Eigen::Vector3d(0, 0, 0.6)).normalized();
        const Eigen::Vector3d hover = grasp_site_ + Eigen::Vector3d(0, 0, 0.005);
        hand.grip_to(kGripOpenTarget_rad, t, 0.2);
        hand.reach(hover, t, reach_time(kLeft, hand.base(), hover, 0.004));
      } else if (hand.reach_done(t)) {
        HL_ENTER(kLeft, Phase::kDescend);
      }
      break;
    case Phase::kDescend:
      if (entering) {
        hand.reach(grasp_site_, t, 0.35 * time_factor_[kLeft]);
        hand.press(-Eigen::Vector3d::UnitZ(), kTouchForce_N * force_factor_, task.params().tissue.stiffness_N_per_m);
      } else if (grasp.holding()) {
        HL_ENTER(kLeft, Phase::kWork);
      } else if (hand.reach_done(t) && hand.grip_done(t) && hand.estimated_force_N() > 0.05 &&
                 t - phase_start_s_[kLeft] > 0.4 * time_factor_[kLeft]) {
        hand.grip_to(kGripShut_rad, t, 0.25);
      } else if (t - phase_start_s_[kLeft] > 3.0) {
        HL_ENTER(kLeft, Phase::kRelease);  // could not get hold: start over
      }
      break;
    case Phase::kWork:
      if (entering) {
        hand.stop_press();
        hand.press(pull_dir_, tension_N * rng_.lognormal_factor(kForceReproductionLogSd),
                   task.params().grasp.stiffness_N_per_m);
      }
      if (done || !grasp.holding() || (target - grasp.anchor()).norm() > 0.014)
        HL_ENTER(kLeft, Phase::kRelease);
      break;
    case Phase::kRelease:
      if (release(kLeft, t, entering, 0.006, 0.2))
        HL_ENTER(kLeft, done ? Phase::kRetract : Phase::kApproach);
      break;
    case Phase::kRetract:
      if (retract(kLeft, t, entering)) HL_ENTER(kLeft, Phase::kDone);
      break;
    case Phase::kDone:
      break;
  }
}

void Participant::act_dissection(double t) noexcept {
  const bool done = dissection_->complete();
  dissection_cautery(t, done);
  dissection_grasper(t, done);
}

// --- left hand: grasp the duct beside the marker and hold it up gently
inline void Participant::clip_grasper(double t, bool done, double marker) noexcept {
  const ClipTask& task = *clip_;
  const auto& p = task.params();
  const auto& grasp = task.grasp();
  Hand& hand = hands_[kLeft];
  const bool entering = phase_start_s_[kLeft] < 0.0;
  if (entering) phase_start_s_[kLeft] = t;
  switch (phase_[kLeft]) {
    case Phase::kApproach:
      if (done) { HL_ENTER(kLeft, Phase::kRetract); break; }
      if (entering) {
        grasp_site_ = task.axis_point(marker - 0.008);
        const Eigen::Vector3d hover = grasp_site_ + Eigen::Vector3d(0, 0, p.duct_radius_m + 0.006);
        hand.grip_to(kGripOpenTarget_rad, t, 0.2);
        hand.reach(hover, t, reach_time(kLeft, hand.base(), hover, 0.003));
      } else if (hand.reach_done(t)) {
        HL_ENTER(kLeft, Phase::kDescend);
      }
      break;
    case Phase::kDescend:
      if (entering) {
        hand.reach(grasp_site_, t, 0.4 * time_factor_[kLeft]);
      } else if (grasp.holding()) {
        HL_ENTER(kLeft, Phase::kWork);
      } else if (hand.reach_done(t) && hand.grip_done(t) &&
                 t - phase_start_s_[kLeft] > 0.5 * time_factor_[kLeft]) {
        hand.grip_to(kGripShut_rad, t, 0.25);
      } else if (t - phase_start_s_[kLeft] > 3.0) {
        HL_ENTER(kLeft, Phase::kRelease);  // could not get hold: start over
      }
      break;
    case Phase::kWork:
      if (entering) {
        pull_dir_ = Eigen::Vector3d::UnitZ();
        hand.press(pull_dir_, kLiftForce_N * force_factor_ * rng_.lognormal_factor(kForceReproductionLogSd),
                   p.grasp.stiffness_N_per_m);
      }
      if (done || !grasp.holding() || std::abs(grasp.anchor().x() - marker) > 0.014)
        HL_ENTER(kLeft, Phase::kRelease);
      break;
    case Phase::kRelease:
      if (release(kLeft, t, entering, 0.006, 0.2))
        HL_ENTER(kLeft, done ? Phase::kRetract : Phase::kApproach);
      break;
    case Phase::kRetract:
      if (retract(kLeft, t, entering)) HL_ENTER(kLeft, Phase::kDone);
      break;
    case Phase::kDone:
      break;
  }
}

// --- right hand: the clip applier
inline void Participant::clip_applier(double t, bool done, double marker) noexcept {
  const ClipTask& task = *clip_;
  const auto& p = task.params();
  const auto& grasp = task.grasp();
  Hand& hand = hands_[kRight];
  const bool entering = phase_start_s_[kRight] < 0.0;
  if (entering) phase_start_s_[kRight] = t;
  const Eigen::Vector3d top = task.axis_point(marker) + Eigen::Vector3d(0, 0, p.duct_radius_m);
  // The applier slipped down beside the duct instead of sitting on it.
  const bool slid_off = tip_[kRight].z() < p.duct_z_m &&
                        std::abs(tip_[kRight].y() - task.duct_y_m()) > 0.8 * p.duct_radius_m;
  // The applier pressed through the duct and is below it. The duct wall
  // is a spring that gives at most stiffness x radius (0.375 N unheld), so
  // a hand that reads the force low by eye presses on and pops through. A
  // person who sees that lifts, aims again and presses more gently; one
  // who presses as hard again pops through on every attempt, and the
  // trial runs into its time limit.
  const bool pushed_through = std::abs(tip_[kRight].x()) <= p.duct_half_length_m &&
                              tip_[kRight].z() < p.duct_z_m - p.duct_radius_m;
  switch (phase_[kRight]) {
    case Phase::kApproach:
      if (done) { HL_ENTER(kRight, Phase::kRetract); break; }
      if (entering) {
        const Eigen::Vector3d hover = top + Eigen::Vector3d(0, 0, 0.008);
        hand.grip_to(kGripOpenTarget_rad, t, 0.2);
        hand.reach(hover, t, reach_time(kRight, hand.base(), hover, 0.002));
      } else if (hand.reach_done(t) && (grasp.holding() || t - phase_start_s_[kRight] > 4.0) &&
                 (hand.aim_error_m() < 0.001 || t - phase_start_s_[kRight] > 3.0)) {
        // Aim first (the seen tip over the marker), then go down.
        HL_ENTER(kRight, Phase::kDescend);
      }
      break;
    case Phase::kDescend:
      if (!entering && (slid_off || pushed_through)) {
        if (pushed_through) seat_force_scale_ *= kGentlerAfterPushThrough;
        HL_ENTER(kRight, Phase::kRelease);  // off the duct: lift and aim again
        break;
      }
      if (entering) {
        hand.reach(top, t, 0.4 * time_factor_[kRight]);
        hand.press(-Eigen::Vector3d::UnitZ(),
                   kSeatForce_N * seat_force_scale_ * force_factor_ *
                       rng_.lognormal_factor(kForceReproductionLogSd),
                   p.duct.stiffness_N_per_m);
      } else if (hand.reach_done(t) &&
                 ((hand.seen_depth_m() > 0.0003 && hand.estimated_force_N() >= 0.5 * hand.target_force_N()) ||
                  t - phase_start_s_[kRight] > 2.5 * time_factor_[kRight])) {
        // Close only once the applier is seen (or felt) seated on the duct.
        HL_ENTER(kRight, Phase::kWork);
      }
      break;
    case Phase::kWork:
      if (entering) hand.grip_to(kGripShut_rad, t, 0.3 * time_factor_[kRight]);
      if (slid_off && hand.grip_done(t)) {
        HL_ENTER(kRight, Phase::kRelease);  // slid off the duct: lift and aim again
        break;
      }
      if (task.clips_applied() > clip_index_) {
        clip_index_ = task.clips_applied();
        HL_ENTER(kRight, Phase::kRelease);
      } else if (task.clips_missed() > clips_seen_missed_) {
        clips_seen_missed_ = task.clips_missed();
        HL_ENTER(kRight, Phase::kRelease);
      } else if (hand.grip_done(t) && t - phase_start_s_[kRight] > 1.5) {
        HL_ENTER(kRight, Phase::kRelease);
      }
      break;
    case Phase::kRelease:
      if (release(kRight, t, entering, 0.008, 0.25))
        HL_ENTER(kRight, done ? Phase::kRetract : Phase::kApproach);
      break;
    case Phase::kRetract:
      if (retract(kRight, t, entering)) HL_ENTER(kRight, Phase::kDone);
      break;
    case Phase::kDone:
      break;
  }
}

void Participant::act_clip(double t) noexcept {
  const ClipTask& task = *clip_;
  const bool done = task.complete();
  const int k = std::min(clip_index_, ClipTask::kClipsPerDuct - 1);
  const double marker = task.marker_x_m(k);
  clip_grasper(t, done, marker);
  clip_applier(t, done, marker);
}

#undef HL_ENTER

}  // namespace hapticlab
