#pragma once

namespace hapticlab {

// A position-dependent force in linearized form, F(x') ≈ force − stiffness·(x' − x),
// so an implicit integrator (VirtualMass) can treat stiff springs stably.
// Units: [F] and [F/X] (see axis_settings.h).
struct LinearizedForce {
  double force = 0.0;
  double stiffness = 0.0;  // >= 0: only restoring stiffness is treated implicitly

  LinearizedForce& operator+=(const LinearizedForce& o) noexcept {
    force += o.force;
    stiffness += o.stiffness;
    return *this;
  }
};

}  // namespace hapticlab
