#pragma once
// A point mass (or rotor) with Karnopp friction to ground (thesis eq. 2.13,
// 2.14), advanced with backward Euler. Inertia and backlash both use it.
//
// The forces acting on the mass are passed in linearized form
//   F(x', v') = force − stiffness·(x' − x) − damping·v'
// so coupling springs, pre-sliding springs and dampers are integrated
// implicitly: the step is stable and dissipative for any dt, which is what
// keeps the models passive at 150 Hz as well as at 2 kHz.
//
// Karnopp: while |v| < v_stick and |F| <= F_static the mass is stuck (v = 0);
// otherwise it slides against −F_dynamic·sign(v). Zero parameters give a
// frictionless mass.

#include "core/settings/axis_settings.h"

namespace hapticlab {

struct KarnoppFriction {
  double static_friction = 0.0;   // [F]
  double dynamic_friction = 0.0;  // [F]
  double stick_velocity = 0.0;    // [X/s]
};

struct MassForces {
  double force = 0.0;      // [F] at the current position and v' = 0
  double stiffness = 0.0;  // [F/X] >= 0
  double damping = 0.0;    // [F·s/X] >= 0
};

class VirtualMass {
 public:
  void reset(double position, double velocity) noexcept {
    position_ = position;
    velocity_ = velocity;
  }
  void step(const MassForces& f, double mass, const KarnoppFriction& friction,
            double dt_s) noexcept;

  double position() const noexcept { return position_; }
  double velocity() const noexcept { return velocity_; }
  void set_position(double position) noexcept { position_ = position; }

 private:
  double position_ = 0.0;
  double velocity_ = 0.0;
};

// B = ζ·2·sqrt(K·m): the thesis gives the coupling damper as a fraction of
// critical damping (Table 2.2).
double coupling_damping(const InertiaParams& p) noexcept;

}  // namespace hapticlab
