#include "core/models/backlash.h"

#include <algorithm>

namespace hapticlab {

void Backlash::reset(double x_hi, double v_hi) noexcept {
  mass_.reset(x_hi, v_hi);
  average_.reset();
}

void Backlash::confine(double x_hi, double gap) noexcept {
  mass_.set_position(limited_position(x_hi, gap));
}

double Backlash::limited_position(double x_hi, double gap) const noexcept {
  return std::clamp(mass_.position(), x_hi - 0.5 * gap, x_hi + 0.5 * gap);
}

bool Backlash::at_wall(double x_hi, double gap) const noexcept {
  return limited_position(x_hi, gap) != mass_.position();
}

double Backlash::step(const InertiaParams& inertia, const BacklashParams& p, double x_hi,
                      double v_hi, const LinearizedForce& on_mass, double dt_s) noexcept {
  const double k = inertia.stiffness;
  const double b = coupling_damping(inertia);
  const KarnoppFriction karnopp{p.static_friction, p.dynamic_friction, p.stick_velocity};
  const MassForces free{on_mass.force, on_mass.stiffness, 0.0};

  // Penetration of the instrument into a gap wall (eq. 2.7), > 0 pushes the
  // mass forward, < 0 backward.
  const double half_gap = 0.5 * p.gap;
  const double ahead = x_hi - (mass_.position() + half_gap);
  const double behind = x_hi - (mass_.position() - half_gap);
  const double penetration = ahead > 0.0 ? ahead : (behind < 0.0 ? behind : 0.0);

  double contact_on_mass = 0.0;
  if (penetration != 0.0) {
    // Coupling attached at the wall, p_vc = x_hi - penetration (eq. 2.8).
    const double attach = mass_.position() + (penetration > 0.0 ? half_gap : -half_gap);
    const VirtualMass before = mass_;
    MassForces engaged = free;
    engaged.force += k * (x_hi - attach) + b * v_hi;
    engaged.stiffness += k;
    engaged.damping += b;
    mass_.step(engaged, inertia.mass, karnopp, dt_s);
    const double wall = mass_.position() + (penetration > 0.0 ? half_gap : -half_gap);
    contact_on_mass = k * (x_hi - wall) + b * (v_hi - mass_.velocity());
    if (contact_on_mass * penetration < 0.0) {
      // The damper would pull the walls apart: contact is unilateral, so the
      // instrument has let go during this step.
      mass_ = before;
      mass_.step(free, inertia.mass, karnopp, dt_s);
      contact_on_mass = 0.0;
    }
  } else {
    mass_.step(free, inertia.mass, karnopp, dt_s);
  }
  return average_.add(-contact_on_mass, dt_s);
}

}  // namespace hapticlab
