#include "core/models/virtual_mass.h"

#include <cmath>

#include "core/common/sign.h"

namespace hapticlab {

double coupling_damping(const InertiaParams& p) noexcept {
  return p.damping_ratio * 2.0 * std::sqrt(p.stiffness * p.mass);
}

void VirtualMass::step(const MassForces& f, double mass, const KarnoppFriction& friction,
                       double dt_s) noexcept {
  if (!(dt_s > 0.0)) return;

  const bool slow = std::abs(velocity_) < friction.stick_velocity;
  if (slow && std::abs(f.force) <= friction.static_friction) {
    velocity_ = 0.0;  // eq. 2.13: friction balances the other forces
    return;
  }
  // eq. 2.14; starting from (near) rest the mass breaks away along the net force.
  const double dir = slow ? sign(f.force) : sign(velocity_);
  const double driving = f.force - friction.dynamic_friction * dir;
  double v = (mass * velocity_ + dt_s * driving) /
             (mass + dt_s * f.damping + dt_s * dt_s * f.stiffness);
  // Friction can stop the mass but not reverse it within one step.
  if (friction.dynamic_friction > 0.0 && v * dir < 0.0 && velocity_ * dir >= 0.0) v = 0.0;
  velocity_ = v;
  position_ += dt_s * v;
}

}  // namespace hapticlab
