#pragma once
// Nahvi–Hollerbach stick–slip friction with a pre-sliding spring, one DOF
// (thesis eq. 2.10–2.12), normal force taken as one unit.
//
//   slip  (|v| >= v_stick):  F = −μ_d·sign(v)
//   stick (|v| <  v_stick):  F = −K_f·(x − x_c),   K_f = μ_d / d_p
//
// On slip→stick the stick centre is placed at x_c = x − d_p·sign(v) (eq. 2.12)
// so the force is continuous. In stick, once |x − x_c| exceeds d_p the spring
// breaks away (force magnitude μ_d) and the contact slips again; while the
// velocity stays below v_stick it re-attaches at once, so very slow motion
// drags the stick centre and the force stays at μ_d. The force never exceeds
// μ_d. Units: [F] force or torque, [X] position (see axis_settings.h).

#include "core/models/linearized_force.h"
#include "core/settings/axis_settings.h"

namespace hapticlab {

class Friction {
 public:
  // Starts in stick with no force at `position`.
  void reset(double position) noexcept;

  // Friction force on the moving body at position x with velocity v.
  LinearizedForce step(const FrictionParams& p, double x, double v) noexcept;

  bool sticking() const noexcept { return sticking_; }
  double stick_centre() const noexcept { return stick_centre_; }
  // Keeps the current force while the position jumps by `shift` (re-anchoring
  // after a stall).
  void shift(double shift) noexcept { stick_centre_ += shift; }

 private:
  bool sticking_ = true;
  double stick_centre_ = 0.0;
  double last_force_ = 0.0;
};

}  // namespace hapticlab
