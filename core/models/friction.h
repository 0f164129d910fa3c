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

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/common/sign.h"
#include "core/models/linearized_force.h"
#include "core/settings/axis_settings.h"

namespace hapticlab {

class Friction {
 public:
  // Starts in stick with no force at `position`.
  void reset(double position) noexcept;

  // Friction force on the moving body at position x with velocity v.
  LinearizedForce step(const FrictionParams& p, double x, double v) noexcept {
    return step(p, presliding_stiffness(p), x, v);
  }
  // The same with k = presliding_stiffness(p) computed beforehand (once per
  // settings change rather than once per update). Inline: it runs on every
  // axis with friction, every update.
  LinearizedForce step(const FrictionParams& p, double k, double x, double v) noexcept {
    const double mu = p.dynamic_level;
    const double dp = p.presliding_displacement;
    if (!sticking_ && std::abs(v) < p.stick_velocity) {
      // Slip -> stick. Attach so that the spring force equals the slip force
      // (eq. 2.12); with v == 0 keep the direction of the last slip force.
      const double dir = v != 0.0 ? sign(v) : -sign(last_force_);
      stick_centre_ = x - dp * dir;
      sticking_ = true;
    }
    if (sticking_) {
      const double stretch = x - stick_centre_;
      if (std::abs(stretch) <= dp) {
        last_force_ = -mu * (stretch / dp);
        return {last_force_, k};
      }
      // Breakaway: the pre-sliding spring ruptures.
      sticking_ = false;
      if (std::abs(v) < p.stick_velocity) {
        // Still slow: re-attach at the edge of the pre-sliding range, which
        // drags the stick centre along with the motion.
        stick_centre_ = x - dp * sign(stretch);
        sticking_ = true;
        last_force_ = -mu * sign(stretch);
        return {last_force_, k};
      }
      last_force_ = -mu * sign(v);
      return {last_force_, 0.0};
    }
    last_force_ = -mu * sign(v);
    return {last_force_, 0.0};
  }

  // K_f = μ_d/d_p, the stiffness handed to an implicit integrator while
  // sticking. The pre-sliding range d_p may be any positive number,
  // subnormals included: μ_d/d_p then overflows to infinity, and −K_f·0 at
  // rest would be NaN. So the force is −μ_d·(stretch/d_p) (|stretch/d_p| <= 1),
  // and this stiffness is capped at the largest double: dt²·K_f stays
  // finite, and the mass is held just as firmly.
  static double presliding_stiffness(const FrictionParams& p) noexcept {
    return std::min(p.dynamic_level / p.presliding_displacement, std::numeric_limits<double>::max());
  }

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
