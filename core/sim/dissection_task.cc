#include "core/sim/dissection_task.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/common/random.h"
#include "core/loop/workspace.h"

namespace hapticlab {

namespace {

// Base structure (and exposed tissue) lies this far below the covering
// tissue's surface: the thickness of the covering layer.
constexpr double kCoverThickness_m = 0.002;

}  // namespace

DissectionTask::DissectionTask(std::uint64_t layout_seed, const DissectionParams& params)
    : params_(params) {
  nx_ = static_cast<int>(std::lround(2.0 * params_.half_width_x_m / params_.cell_m));
  ny_ = static_cast<int>(std::lround(2.0 * params_.half_width_y_m / params_.cell_m));
  const auto n = static_cast<std::size_t>(nx_ * ny_);
  health_.assign(n, 1.0f);
  on_line_.assign(n, 0);

  // The line: from the marker near the left edge to near the right edge,
  // meandering by a few mm; the branch leaves at the midpoint towards the
  // front or the back edge.
  Random rng = Random::derive(layout_seed, 0x6469737365637431ull);
  const double x0 = -params_.half_width_x_m + 0.005, x1 = params_.half_width_x_m - 0.005;
  const double y_limit = params_.half_width_y_m - 0.005;
  const double y_start = rng.uniform(-0.004, 0.004);
  const double a1 = rng.uniform(0.0015, 0.004), p1 = rng.uniform(0.0, 2.0 * std::numbers::pi);
  const double a2 = rng.uniform(0.0, 0.0015), p2 = rng.uniform(0.0, 2.0 * std::numbers::pi);
  auto main_y = [&](double s) {  // s in [0, 1] along the main line
    return std::clamp(y_start + a1 * (std::sin(std::numbers::pi * s + p1) - std::sin(p1)) +
                          a2 * (std::sin(3.0 * std::numbers::pi * s + p2) - std::sin(p2)),
                      -y_limit, y_limit);
  };
  auto add_sample = [&](double x, double y) {
    const int c = cell_at(x, y);
    if (c >= 0 && !on_line_[static_cast<std::size_t>(c)]) {
      on_line_[static_cast<std::size_t>(c)] = 1;
      line_path_.push_back(c);
    }
  };
  constexpr double kStep_m = 0.0004;
  const int main_steps = static_cast<int>((x1 - x0) / kStep_m);
  for (int k = 0; k <= main_steps; ++k) {
    const double s = static_cast<double>(k) / main_steps;
    add_sample(x0 + s * (x1 - x0), main_y(s));
  }
  branch_start_ = static_cast<int>(line_path_.size());
  const double xj = 0.5 * (x0 + x1), yj = main_y(0.5);
  const double side = rng.uniform() < 0.5 ? -1.0 : 1.0;
  const double xb = xj + rng.uniform(0.008, 0.014);
  const double yb = std::clamp(yj + side * rng.uniform(0.010, 0.013), -y_limit - 0.002, y_limit + 0.002);
  const double branch_len = std::hypot(xb - xj, yb - yj);
  const int branch_steps = static_cast<int>(branch_len / kStep_m);
  for (int k = 1; k <= branch_steps; ++k) {
    const double s = static_cast<double>(k) / branch_steps;
    add_sample(xj + s * (xb - xj), yj + s * (yb - yj));
  }
  remaining_line_cells_ = static_cast<int>(line_path_.size());
}

int DissectionTask::cell_at(double x_m, double y_m) const noexcept {
  const int ix = static_cast<int>(std::floor((x_m + params_.half_width_x_m) / params_.cell_m));
  const int iy = static_cast<int>(std::floor((y_m + params_.half_width_y_m) / params_.cell_m));
  if (!(ix >= 0 && ix < nx_ && iy >= 0 && iy < ny_)) return -1;
  return iy * nx_ + ix;
}

Eigen::Vector3d DissectionTask::cell_center(int cell) const noexcept {
  const int ix = cell % nx_, iy = cell / nx_;
  return {-params_.half_width_x_m + (ix + 0.5) * params_.cell_m,
          -params_.half_width_y_m + (iy + 0.5) * params_.cell_m, params_.surface_z_m};
}

void DissectionTask::step(const VeInput& in, VeOutput& out, EventBuffer& events) noexcept {
  constexpr int kLeft = 0, kRight = 1;
  std::array<double, 2> normal_force_N{0.0, 0.0};
  std::array<int, 2> cell{-1, -1};
  std::array<Eigen::Vector3d, 2> tip;
  for (int i = 0; i < 2; ++i) {
    const auto ui = static_cast<std::size_t>(i);
    const auto& j = in.joints[ui];
    tip[ui] = in.tip_m[ui];
    const Eigen::Vector3d v = tools_.tip_velocity(i, tip[ui], in.dt_s);
    cell[ui] = cell_at(tip[ui].x(), tip[ui].y());
    const bool covered = cell[ui] >= 0 && !removed(cell[ui]);
    const double surface_z = covered ? params_.surface_z_m : params_.surface_z_m - kCoverThickness_m;
    const ContactParams& contact = covered ? params_.tissue : params_.structure;
    const double depth_m = surface_z - tip[ui].z();
    Eigen::Vector3d f = contact_force(contact, depth_m, -v.z(), Eigen::Vector3d::UnitZ());
    normal_force_N[ui] = f.z();

    if (i == kLeft) {
      const double grip = j[kJointGrip];
      if (grasp_.holding()) {
        if (grip > kGripOpen_rad || grasp_.stretch_m(tip[ui]) > params_.grasp.max_stretch_m) {
          grasp_.release();
          events.push({in.t_s, TaskEventType::kGraspEnd, kLeft, 0});
        }
      } else if (grip < kGripClosed_rad && depth_m > 0.0 && covered) {
        grasp_.take({tip[ui].x(), tip[ui].y(), params_.surface_z_m});
        events.push({in.t_s, TaskEventType::kGraspStart, kLeft, cell[ui]});
      }
      const Eigen::Vector3d fg = grasp_.force(params_.grasp, tip[ui], v);
      tension_N_ = fg.norm();
      f += fg;
    }
    out.tip_force_N[ui] = f;
    out.grip_torque_Nm[ui] = 0.0;
    out.in_contact[ui] = depth_m > 0.0 || (i == kLeft && grasp_.holding());
    tools_.update(i, in.t_s, j[kJointInsertion], out.in_contact[ui], events);
  }

  // Cautery: burn covering tissue under the right tool.
  const double f_n = normal_force_N[kRight];
  if (f_n > params_.burn_threshold_N && cell[kRight] >= 0) {
    const double tension_gain = 1.0 + std::min(1.0, tension_N_ / params_.tension_reference_N);
    const double rate = params_.burn_rate_per_s * (f_n - params_.burn_threshold_N) /
                        params_.burn_threshold_N * tension_gain;
    const auto loss = static_cast<float>(rate * in.dt_s);
    const int cx = cell[kRight] % nx_, cy = cell[kRight] / nx_;
    const double r2 = params_.burn_radius_m * params_.burn_radius_m;
    for (int iy = std::max(0, cy - 1); iy <= std::min(ny_ - 1, cy + 1); ++iy) {
      for (int ix = std::max(0, cx - 1); ix <= std::min(nx_ - 1, cx + 1); ++ix) {
        const int c = iy * nx_ + ix;
        const auto uc = static_cast<std::size_t>(c);
        if (health_[uc] <= 0.0f) continue;
        const Eigen::Vector3d center = cell_center(c);
        const double dx = center.x() - tip[kRight].x(), dy = center.y() - tip[kRight].y();
        if (c != cell[kRight] && dx * dx + dy * dy > r2) continue;
        health_[uc] -= loss;
        if (health_[uc] <= 0.0f) {
          events.push({in.t_s, TaskEventType::kTissueRemoved, kRight, c});
          if (on_line_[uc]) --remaining_line_cells_;
        }
      }
    }
  }
  if (remaining_line_cells_ == 0 && !reported_complete_) {
    reported_complete_ = true;
    events.push({in.t_s, TaskEventType::kTaskComplete, -1, 0});
  }
}

}  // namespace hapticlab
