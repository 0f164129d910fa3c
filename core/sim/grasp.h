#pragma once
// A grasper holding tissue: while the jaws are closed on it, the tissue is
// a spring–damper between the tip and the point where it was grasped, so
// pulling the tool tensions the tissue.

#include <Eigen/Core>

namespace hapticlab {

// Jaw angles (grip joint, rad; the LSW grip opens 0..20°): closing below
// kGripClosed_rad takes hold, opening above kGripOpen_rad lets go. The gap
// between the two keeps a trembling hand from toggling the grasp.
inline constexpr double kGripClosed_rad = 0.08;
inline constexpr double kGripOpen_rad = 0.16;

struct GraspParams {
  double stiffness_N_per_m = 120.0;
  double damping_N_s_per_m = 1.5;
  double max_stretch_m = 0.03;  // tissue tears free beyond this
};

class Grasp {
 public:
  bool holding() const noexcept { return holding_; }
  const Eigen::Vector3d& anchor() const noexcept { return anchor_; }
  void take(const Eigen::Vector3d& anchor) noexcept {
    holding_ = true;
    anchor_ = anchor;
  }
  void release() noexcept { holding_ = false; }

  // Force of the tissue on the tip [N].
  Eigen::Vector3d force(const GraspParams& p, const Eigen::Vector3d& tip_m,
                        const Eigen::Vector3d& tip_velocity_m_per_s) const noexcept {
    if (!holding_) return Eigen::Vector3d::Zero();
    return -p.stiffness_N_per_m * (tip_m - anchor_) - p.damping_N_s_per_m * tip_velocity_m_per_s;
  }
  double stretch_m(const Eigen::Vector3d& tip_m) const noexcept {
    return holding_ ? (tip_m - anchor_).norm() : 0.0;
  }

 private:
  bool holding_ = false;
  Eigen::Vector3d anchor_ = Eigen::Vector3d::Zero();
};

}  // namespace hapticlab
