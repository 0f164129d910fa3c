#include "core/models/friction.h"

#include <cmath>

namespace hapticlab {
namespace {
double sign(double v) noexcept { return v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0); }
}  // namespace

void Friction::reset(double position) noexcept {
  sticking_ = true;
  stick_centre_ = position;
  last_force_ = 0.0;
}

LinearizedForce Friction::step(const FrictionParams& p, double x, double v) noexcept {
  const double mu = p.dynamic_level;
  const double dp = p.presliding_displacement;
  const double k = mu / dp;

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
      last_force_ = -k * stretch;
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
