#pragma once
// Backlash, one DOF (thesis 2.2.2, eq. 2.7–2.8, Fig. 2-4 and 2-11). The
// virtual mass of the inertia model (the lumped motor and transmission) sits
// in a gap of width d around the instrument. While the instrument is inside
// the gap no force is felt. When it passes a gap wall the virtual coupling
// (K, B of the inertia settings) engages at that wall, p_vc = x_vm ± d/2:
//
//   F_hi = −(K·(x_hi − p_vc) + B·(v_hi − v_vm))   only while it pushes (unilateral)
//
// The VE, cogging and friction forces act on the mass (Fig. 2-11), and their
// position input is the mass position limited to within d/2 of the
// instrument: that position is also what the VE is shown, so the visual gap
// walls are infinitely stiff. Karnopp friction on the free mass keeps it from
// rattling between the walls.

#include <algorithm>

#include "core/models/linearized_force.h"
#include "core/models/moving_average.h"
#include "core/models/virtual_mass.h"

namespace hapticlab {

class Backlash {
 public:
  // Centres the mass on the instrument.
  void reset(double x_hi, double v_hi) noexcept;
  // Keeps the mass within the (possibly new) gap of the instrument.
  void confine(double x_hi, double gap) noexcept;

  // Mass position limited to x_hi ± gap/2: the position the VE sees and the
  // input of the VE, cogging and friction models.
  double limited_position(double x_hi, double gap) const noexcept {
    // std::clamp is min(max(x, lo), hi): maxsd and minsd, no branch.
    return std::clamp(mass_.position(), x_hi - 0.5 * gap, x_hi + 0.5 * gap);
  }
  // True when the mass is held at a gap wall (the instrument pushes it).
  bool at_wall(double x_hi, double gap) const noexcept {
    return limited_position(x_hi, gap) != mass_.position();
  }

  // `on_mass` are the VE, cogging and friction forces (linearized in the mass
  // position). Returns the force on the instrument [F].
  double step(const InertiaParams& inertia, const BacklashParams& p, double x_hi, double v_hi,
              const LinearizedForce& on_mass, double dt_s) noexcept {
    return step(inertia, coupling_damping(inertia), karnopp(p), p, x_hi, v_hi, on_mass, dt_s);
  }
  // The same with b = coupling_damping(inertia) and karnopp(p) computed
  // beforehand (once per settings change). Inline: it runs on every axis
  // with backlash, every update.
  double step(const InertiaParams& inertia, double b, const KarnoppFriction& karnopp,
              const BacklashParams& p, double x_hi, double v_hi, const LinearizedForce& on_mass,
              double dt_s) noexcept {
    const double k = inertia.stiffness;
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

  // The Karnopp friction of the free mass.
  static KarnoppFriction karnopp(const BacklashParams& p) noexcept {
    return {p.static_friction, p.dynamic_friction, p.stick_velocity};
  }

  const VirtualMass& mass() const noexcept { return mass_; }

 private:
  VirtualMass mass_;
  ShortWindowAverage average_;
};

}  // namespace hapticlab
