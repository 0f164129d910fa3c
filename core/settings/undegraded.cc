// The order the fields are looked at is the settings file's (settings_json.h),
// so the effect named is the one a reader finds first.
#include "core/settings/undegraded.h"

namespace hapticlab {
namespace {

std::string first_axis_effect_on(const AxisSettings& a) {
  if (a.friction.enabled) return "friction";
  if (a.cogging.enabled) return "cogging";
  if (a.saturation.enabled) return "saturation";
  if (a.inertia.enabled) return "inertia";
  if (a.backlash.enabled) return "backlash";
  if (a.encoder.enabled) return "encoder";
  if (a.passivity.enabled) return "passivity";
  return {};
}

}  // namespace

std::string first_effect_on(const EngineSettings& s) {
  if (const std::string e = first_axis_effect_on(s.translation); !e.empty()) return "translation." + e;
  if (const std::string e = first_axis_effect_on(s.rotation); !e.empty()) return "rotation." + e;
  if (s.tip_force_saturation.enabled) return "tip_force_saturation";
  if (s.loop.hold_rate_Hz > 0.0) return "loop.hold_rate_Hz";
  if (s.loop.position_latency_s > 0.0) return "loop.position_latency_s";
  if (s.loop.force_latency_s > 0.0) return "loop.force_latency_s";
  return {};
}

}  // namespace hapticlab
