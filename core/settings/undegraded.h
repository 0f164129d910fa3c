#pragma once
// What makes a setting "undegraded" (the device as it is, as
// examples/settings/high_fidelity.json): every effect model of both axes
// off, no tip force saturation, no loop emulation. A study's control is
// measured against, so a control that degrades something makes every
// comparison with it measure the wrong difference. device_limits and
// min_moment_arm_m are the device under the engine, not an effect: they
// are not looked at.
#include <string>

#include "core/settings/settings.h"

namespace hapticlab {

// The first effect that is on, as its settings field reads in a settings
// file ("translation.friction", "tip_force_saturation",
// "loop.hold_rate_Hz", ...); empty when the settings are undegraded.
std::string first_effect_on(const EngineSettings& settings);

}  // namespace hapticlab
