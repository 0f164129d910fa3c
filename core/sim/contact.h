#pragma once
// Tissue contact: a spring–damper acting along the surface normal while the
// tool tip is inside the tissue, and the per-tool bookkeeping every task
// shares (contact and 20 mm insertion events).
//
// Soft tissue: stiffnesses of a few hundred N/m put 1 N at 3–5 mm of
// indentation, the force range the thesis measured (mostly below 1–3 N).

#include <array>

#include <Eigen/Core>

#include "core/loop/task_event.h"

namespace hapticlab {

struct ContactParams {
  double stiffness_N_per_m = 250.0;  // > 0
  double damping_N_s_per_m = 2.0;    // >= 0
};

// Force on the tip for indentation `depth_m` (> 0 inside) growing at
// `depth_rate_m_per_s`, pushing out along the unit `outward_normal`. The
// damper only adds to a pushing force: tissue does not pull the tool back in.
inline Eigen::Vector3d contact_force(const ContactParams& p, double depth_m, double depth_rate_m_per_s,
                                     const Eigen::Vector3d& outward_normal) noexcept {
  if (depth_m <= 0.0) return Eigen::Vector3d::Zero();
  double magnitude = p.stiffness_N_per_m * depth_m + p.damping_N_s_per_m * depth_rate_m_per_s;
  if (magnitude < 0.0) magnitude = 0.0;
  return magnitude * outward_normal;
}

// Emits contact start/end and 20 mm insertion events for the two tools and
// estimates each tip's indentation rate.
class ToolTracker {
 public:
  // Tip velocity [m/s] from successive tip positions, low-pass filtered at
  // 50 Hz so that encoder steps do not kick the tissue dampers.
  Eigen::Vector3d tip_velocity(int instrument, const Eigen::Vector3d& tip_m, double dt_s) noexcept;
  void update(int instrument, double t_s, double insertion_m, bool in_contact,
              EventBuffer& events) noexcept;
  bool in_contact(int instrument) const noexcept { return contact_[static_cast<std::size_t>(instrument)]; }
  // Time of the first and the last contact of any tool [s], −1 if none yet.
  double last_contact_s() const noexcept { return last_contact_s_; }

 private:
  std::array<bool, 2> contact_{false, false};
  std::array<bool, 2> past_mark_{false, false};
  std::array<Eigen::Vector3d, 2> last_tip_m_{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  std::array<Eigen::Vector3d, 2> velocity_{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  std::array<bool, 2> have_tip_{false, false};
  double last_contact_s_ = -1.0;
};

}  // namespace hapticlab
