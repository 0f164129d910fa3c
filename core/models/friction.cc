#include "core/models/friction.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/common/sign.h"

namespace hapticlab {

void Friction::reset(double position) noexcept {
  sticking_ = true;
  stick_centre_ = position;
  last_force_ = 0.0;
}

LinearizedForce Friction::step(const FrictionParams& p, double x, double v) noexcept {
  const double mu = p.dynamic_level;
  const double dp = p.presliding_displacement;
  // The pre-sliding range d_p may be any positive number, subnormals
  // included: μ_d/d_p then overflows to infinity, and −K_f·0 at rest would
  // be NaN. So the force is −μ_d·(stretch/d_p) (|stretch/d_p| <= 1), and the
  // stiffness handed over for implicit integration is capped at the largest
  // double: dt²·K_f stays finite, and the mass is held just as firmly.
  const double k = std::min(mu / dp, std::numeric_limits<double>::max());

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

}  // namespace hapticlab
