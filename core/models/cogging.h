#pragma once
// Cogging and torque ripple, one DOF (thesis 2.2.4 and 4.2.1.1).
//
//   cogging:  F_c = −A·sin(2π·x/p + φ)   (x = 0 is a stable detent for φ = 0)
//   ripple:   F_out = F_cmd·(1 + r·sin(2π·x/p_r))
//
// The thesis fitted a sinusoid to published cogging curves and gave only the
// amplitude. Default periods (settings_json.cc) assume an inexpensive
// 2-pole/3-slot DC motor, which cogs 6 times per motor revolution, behind the
// transmission of a laparoscopic interface: a 10:1 capstan on pitch/yaw gives
// 2π/60 rad (6°); a cable drum moving the insertion axis 60 mm per motor
// revolution gives 10 mm. Both are settings.
// x is the motor-side position: the instrument, or the virtual mass when
// backlash is on (Fig. 2-11).
//
// The engine calls the forms below that take what depends only on the
// settings (CoggingTerms) computed once per settings change, and the sine
// and cosine through a memo (sin_cos.h); they give bit for bit what the
// plain forms give.

#include <numbers>

#include "core/models/linearized_force.h"
#include "core/models/sin_cos.h"
#include "core/settings/axis_settings.h"

namespace hapticlab {

// The factors of the cogging sinusoid that depend only on its parameters.
struct CoggingTerms {
  double wavenumber = 0.0;            // 2π/p [1/X]
  double amplitude_wavenumber = 0.0;  // A·2π/p [F/X]
  explicit CoggingTerms(const CoggingParams& p) noexcept
      : wavenumber(2.0 * std::numbers::pi / p.period), amplitude_wavenumber(p.amplitude * wavenumber) {}
  CoggingTerms() = default;
};

// The angle 2π·x/p + φ of the cogging sinusoid at x.
inline double cogging_angle(const CoggingParams& p, const CoggingTerms& t, double x) noexcept {
  return t.wavenumber * x + p.phase_rad;
}
// The cogging force alone, from the sine of its angle: for a caller that
// does not use the stiffness (which needs the cosine).
inline double cogging_force_from_sin(const CoggingParams& p, double sin_angle) noexcept {
  return -p.amplitude * sin_angle;
}
// Cogging force at the angle whose sine and cosine are given.
inline LinearizedForce cogging_force(const CoggingParams& p, const CoggingTerms& t, SinCos angle) noexcept {
  const double stiffness = t.amplitude_wavenumber * angle.cos;
  return {cogging_force_from_sin(p, angle.sin), stiffness > 0.0 ? stiffness : 0.0};
}

// Cogging force at x, with its restoring stiffness A·(2π/p)·cos(...) where
// positive (near stable detents).
inline LinearizedForce cogging_force(const CoggingParams& p, double x) noexcept {
  const CoggingTerms t(p);
  return cogging_force(p, t, sin_cos(cogging_angle(p, t, x)));
}

// The argument 2π·x/p_r of the ripple's sine.
inline double ripple_angle(const CoggingParams& p, double x) noexcept {
  return 2.0 * std::numbers::pi * x / p.ripple_period;
}
// Scale factor 1 + r·sin(2π·x/p_r) applied to the commanded force, given
// that sine.
inline double ripple_gain_from_sin(const CoggingParams& p, double sin_angle) noexcept {
  return 1.0 + p.ripple_fraction * sin_angle;
}
// Scale factor 1 + r·sin(2π·x/p_r) applied to the commanded force.
inline double ripple_gain(const CoggingParams& p, double x) noexcept {
  if (p.ripple_fraction == 0.0) return 1.0;
  return ripple_gain_from_sin(p, poly_sin(ripple_angle(p, x)));
}

}  // namespace hapticlab
