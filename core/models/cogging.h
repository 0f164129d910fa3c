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

#include "core/models/linearized_force.h"
#include "core/settings/axis_settings.h"

namespace hapticlab {

// Cogging force at x, with its restoring stiffness A·(2π/p)·cos(...) where
// positive (near stable detents).
LinearizedForce cogging_force(const CoggingParams& p, double x) noexcept;
// Scale factor 1 + r·sin(2π·x/p_r) applied to the commanded force.
double ripple_gain(const CoggingParams& p, double x) noexcept;

}  // namespace hapticlab
