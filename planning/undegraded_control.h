#pragma once
// The plan commands find the control by its name ('High Fidelity'); what
// it does is checked too, because every effect they report is a difference
// from it: a control that degrades something would make "the effect of X"
// the difference between X and that degradation.
#include <string>

#include "protocols/protocol.h"

namespace hapticlab::planning {

// Throws std::runtime_error naming `protocol_path`, the setting `control`
// and its first effect that is on (core/settings/undegraded.h) when the
// control of `protocol` is not undegraded; `command` ("plan power") says
// who refuses it. `control` must be one of the protocol's settings.
void check_control_undegraded(const protocols::Protocol& protocol, const std::string& control,
                              const std::string& protocol_path, const std::string& command);

}  // namespace hapticlab::planning
