#include "core/models/inertia.h"

namespace hapticlab {

void Inertia::reset(double x_hi, double v_hi) noexcept {
  mass_.reset(x_hi, v_hi);
  average_.reset();
}

double Inertia::step(const InertiaParams& p, double x_hi, double v_hi, double dt_s) noexcept {
  const double b = coupling_damping(p);
  // (x_hi, v_hi) => coupling on the mass, implicit in (x_vm', v_vm')
  const MassForces on_mass{p.stiffness * (x_hi - mass_.position()) + b * v_hi, p.stiffness, b};
  mass_.step(on_mass, p.mass, KarnoppFriction{}, dt_s);
  // (x_vm', v_vm') => reaction on the instrument => short average
  const double on_instrument =
      -(p.stiffness * (x_hi - mass_.position()) + b * (v_hi - mass_.velocity()));
  return average_.add(on_instrument, dt_s);
}

}  // namespace hapticlab
