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

#include <cmath>

#include "core/common/sign.h"
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
  // Inline: inertia and backlash step it on every axis, every update.
  void step(const MassForces& f, double mass, const KarnoppFriction& friction,
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

  double position() const noexcept { return position_; }
  double velocity() const noexcept { return velocity_; }
  void set_position(double position) noexcept { position_ = position; }

 private:
  double position_ = 0.0;
  double velocity_ = 0.0;
};

// B = ζ·2·sqrt(K·m): the thesis gives the coupling damper as a fraction of
// critical damping (Table 2.2).
inline double coupling_damping(const InertiaParams& p) noexcept {
  return p.damping_ratio * 2.0 * std::sqrt(p.stiffness * p.mass);
}

}  // namespace hapticlab
