#pragma once
// The thesis' dissection task (3.3.2.1): a light covering tissue lies over a
// dark structure on which a hidden line is painted. The line starts at a
// marker on the left and a second line branches off halfway. The right-hand
// cautery removes covering tissue that it touches with enough force; tissue
// tensioned by the left-hand grasper gives way faster. The task is complete
// when every part of the line is exposed.
//
// The covering tissue is a grid of 2 mm cells on the plane z = surface_z_m.
// A cell under the cautery tip loses "health" at a rate that grows with the
// contact force above the burn threshold and with the grasper's tension;
// at zero health it is gone and the structure below shows (and is touched).

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "core/sim/contact.h"
#include "core/sim/grasp.h"
#include "core/loop/virtual_environment.h"
#include "core/sim/task_kind.h"

namespace hapticlab {

struct DissectionParams {
  double surface_z_m = -0.110;           // covering tissue surface
  double half_width_x_m = 0.030;         // tissue extent around the origin
  double half_width_y_m = 0.020;
  double cell_m = 0.002;                 // grid spacing
  ContactParams tissue{220.0, 1.5};      // covering tissue
  ContactParams structure{320.0, 2.0};   // exposed structure below
  GraspParams grasp{};
  double burn_threshold_N = 0.20;        // cautery needs at least this contact force
  double burn_rate_per_s = 5.0;          // health lost per s at twice the threshold
  double burn_radius_m = 0.0016;         // cells whose centre is this close to the tip burn
  double tension_reference_N = 0.5;      // grasper tension that doubles the burn rate
  double line_halfwidth_m = 0.0012;      // cells this close to the line must be exposed
};

class DissectionTask final : public VirtualEnvironment {
 public:
  // `layout_seed` varies the line's course and the branch, as the thesis'
  // VE did from trial to trial.
  explicit DissectionTask(std::uint64_t layout_seed, const DissectionParams& params = {});

  void step(const VeInput& in, VeOutput& out, EventBuffer& events) noexcept override;
  bool complete() const noexcept override { return remaining_line_cells_ == 0; }
  TaskKind kind() const noexcept { return TaskKind::kDissection; }

  // --- what a participant can see
  const DissectionParams& params() const noexcept { return params_; }
  // Line cells in the order a surgeon would follow them: from the marker
  // along the main line, then the branch from its junction.
  const std::vector<int>& line_path() const noexcept { return line_path_; }
  Eigen::Vector3d cell_center(int cell) const noexcept;
  bool removed(int cell) const noexcept { return health_[static_cast<std::size_t>(cell)] <= 0.0f; }
  int remaining_line_cells() const noexcept { return remaining_line_cells_; }
  int line_cell_count() const noexcept { return static_cast<int>(line_path_.size()); }
  // Index of the branch's first cell in line_path().
  int branch_start() const noexcept { return branch_start_; }
  const Grasp& grasp() const noexcept { return grasp_; }
  double tension_N() const noexcept { return tension_N_; }
  // Cell under a point, −1 outside the tissue.
  int cell_at(double x_m, double y_m) const noexcept;

 private:
  DissectionParams params_;
  int nx_ = 0, ny_ = 0;
  std::vector<float> health_;
  std::vector<std::uint8_t> on_line_;
  std::vector<int> line_path_;
  int branch_start_ = 0;
  int remaining_line_cells_ = 0;
  bool reported_complete_ = false;
  Grasp grasp_;
  double tension_N_ = 0.0;
  ToolTracker tools_;
};

}  // namespace hapticlab
