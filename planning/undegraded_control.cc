// The plan commands' control, checked by what it does (undegraded_control.h).
#include "planning/undegraded_control.h"

#include <stdexcept>

#include "core/settings/undegraded.h"

namespace hapticlab::planning {

void check_control_undegraded(const protocols::Protocol& protocol, const std::string& control,
                              const std::string& protocol_path, const std::string& command) {
  const protocols::ProtocolSetting& s = protocol.settings[*protocol.find_setting(control)];
  const std::string effect = first_effect_on(s.settings.engine);
  if (effect.empty()) return;
  throw std::runtime_error(protocol_path + ": the control '" + control + "' has " + effect +
                           " on, but " + command + " measures every effect against an undegraded control (every "
                           "effect model off, no tip_force_saturation, no loop emulation, as "
                           "examples/settings/high_fidelity.json); switch it off or name another setting 'High "
                           "Fidelity'");
}

}  // namespace hapticlab::planning
