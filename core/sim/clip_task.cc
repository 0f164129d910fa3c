#include "core/sim/clip_task.h"

#include <algorithm>
#include <cmath>

#include "core/loop/workspace.h"

namespace hapticlab {

ClipTask::ClipTask(std::uint64_t layout_seed, const ClipParams& params)
    : params_(params), rng_(Random::derive(layout_seed, 0x636c697073ull)) {
  duct_y_m_ = rng_.uniform(-0.005, 0.005);
  const double center = rng_.uniform(-0.004, 0.004);
  for (int k = 0; k < kClipsPerDuct; ++k)
    marker_x_m_[static_cast<std::size_t>(k)] = center + (k - 1) * params_.marker_spacing_m;
}

void ClipTask::step(const VeInput& in, VeOutput& out, EventBuffer& events) noexcept {
  constexpr int kLeft = 0, kRight = 1;
  for (int i = 0; i < 2; ++i) {
    const auto ui = static_cast<std::size_t>(i);
    const auto& j = in.joints[ui];
    const Eigen::Vector3d& tip = in.tip_m[ui];
    const Eigen::Vector3d v = tools_.tip_velocity(i, tip, in.dt_s);
    const double grip = j[kJointGrip];

    // Duct wall: radial spring–damper within the duct's span.
    Eigen::Vector3d f = Eigen::Vector3d::Zero();
    double duct_depth_m = -1.0;
    const bool over_duct = std::abs(tip.x()) <= params_.duct_half_length_m;
    const Eigen::Vector3d radial(0.0, tip.y() - duct_y_m_, tip.z() - params_.duct_z_m);
    const double dist_m = radial.norm();
    if (over_duct) duct_depth_m = params_.duct_radius_m - dist_m;
    const bool holding_here = i == kLeft && grasp_.holding();
    if (!holding_here && duct_depth_m > 0.0 && dist_m > 1e-9) {
      const Eigen::Vector3d n = radial / dist_m;
      const bool stabilized =
          grasp_.holding() && std::abs(grasp_.anchor().x() - tip.x()) <= params_.stabilization_reach_m;
      f += contact_force(stabilized ? params_.duct_held : params_.duct, duct_depth_m, -v.dot(n), n);
    }
    const double base_depth_m = params_.base_z_m - tip.z();
    f += contact_force(params_.base, base_depth_m, -v.z(), Eigen::Vector3d::UnitZ());

    if (i == kLeft) {
      if (grasp_.holding()) {
        if (grip > kGripOpen_rad || grasp_.stretch_m(tip) > params_.grasp.max_stretch_m) {
          grasp_.release();
          events.push({in.t_s, TaskEventType::kGraspEnd, kLeft, 0});
        }
      } else if (grip < kGripClosed_rad && over_duct &&
                 dist_m <= params_.duct_radius_m + params_.grasp_reach_m) {
        grasp_.take(axis_point(tip.x()));
        events.push({in.t_s, TaskEventType::kGraspStart, kLeft, 0});
      }
      f += grasp_.force(params_.grasp, tip, v);
    }

    out.grip_torque_Nm[ui] = 0.0;
    if (i == kRight) {
      const bool closed_now = grip < kGripClosed_rad;
      if (closed_now && !jaws_closed_ && clips_applied_ < kClipsPerDuct) {
        const double marker = marker_x_m_[static_cast<std::size_t>(clips_applied_)];
        const bool on_duct = over_duct && dist_m <= params_.duct_radius_m + params_.seat_reach_m;
        const bool at_marker = std::abs(tip.x() - marker) <= params_.marker_tolerance_m;
        const double lateral_speed = std::hypot(v.x(), v.y());
        const bool steady = grasp_.holding() || lateral_speed <= params_.still_speed_m_per_s;
        if (on_duct && at_marker && steady && rng_.uniform() >= params_.detection_failure) {
          events.push({in.t_s, TaskEventType::kClipApplied, kRight, clips_applied_});
          ++clips_applied_;
          torque_until_s_ = in.t_s + params_.clip_torque_s;
          if (clips_applied_ == kClipsPerDuct)
            events.push({in.t_s, TaskEventType::kTaskComplete, -1, 0});
        } else {
          events.push({in.t_s, TaskEventType::kClipMissed, kRight, clips_applied_});
          ++clips_missed_;
        }
      }
      if (grip > kGripOpen_rad) jaws_closed_ = false;
      else if (closed_now) jaws_closed_ = true;
      if (in.t_s < torque_until_s_) out.grip_torque_Nm[ui] = params_.clip_torque_Nm;
    }

    out.tip_force_N[ui] = f;
    out.in_contact[ui] = duct_depth_m > 0.0 || base_depth_m > 0.0 || holding_here;
    tools_.update(i, in.t_s, j[kJointInsertion], out.in_contact[ui], events);
  }
}

}  // namespace hapticlab
