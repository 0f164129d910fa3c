#pragma once
// Extra inertia by virtual coupling, one DOF (thesis 2.2.1, eq. 2.1–2.2,
// Fig. 2-2). A virtual mass m is tied to the instrument by a spring K and a
// damper B = ζ·2·sqrt(K·m):
//
//   m·a_vm = K·(x_hi − x_vm) + B·(v_hi − v_vm)
//   F_hi   = −(K·(x_hi − x_vm) + B·(v_hi − v_vm)),  averaged over 3 updates / 20 ms
//
// v_hi is the Butterworth-filtered instrument velocity. For motion slow
// against sqrt(K/m) the mass follows the instrument and F_hi ≈ −m·a_hi.

#include "core/models/moving_average.h"
#include "core/models/virtual_mass.h"

namespace hapticlab {

class Inertia {
 public:
  void reset(double x_hi, double v_hi) noexcept;
  // Returns the force on the instrument [F].
  double step(const InertiaParams& p, double x_hi, double v_hi, double dt_s) noexcept {
    return step(p, coupling_damping(p), x_hi, v_hi, dt_s);
  }
  // The same with b = coupling_damping(p) computed beforehand (once per
  // settings change). Inline: it runs on every axis with inertia, every update.
  double step(const InertiaParams& p, double b, double x_hi, double v_hi, double dt_s) noexcept {
    // (x_hi, v_hi) => coupling on the mass, implicit in (x_vm', v_vm')
    const MassForces on_mass{p.stiffness * (x_hi - mass_.position()) + b * v_hi, p.stiffness, b};
    mass_.step(on_mass, p.mass, KarnoppFriction{}, dt_s);
    // (x_vm', v_vm') => reaction on the instrument => short average
    const double on_instrument =
        -(p.stiffness * (x_hi - mass_.position()) + b * (v_hi - mass_.velocity()));
    return average_.add(on_instrument, dt_s);
  }

  const VirtualMass& mass() const noexcept { return mass_; }

 private:
  VirtualMass mass_;
  ShortWindowAverage average_;
};

}  // namespace hapticlab
