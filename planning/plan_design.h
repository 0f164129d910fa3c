#pragma once
// What plan power needs of a design beyond its protocol, checked before any
// simulation: the control every setting is compared with, and the null
// settings (copies of the control under another name, whose "effects" are
// false positives).
#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "planning/simulated_study.h"
#include "protocols/protocol.h"

namespace hapticlab::planning {

struct PlanDesign {
  std::string control;
  std::set<std::string> null_settings;  // declared ones and undeclared copies of the control
  std::vector<std::string> notes;       // one per undeclared copy, for the user (plan power prints "note: ...")
};

// Throws std::runtime_error naming `protocol_path` when the protocol has no
// control, when the control degrades something (undegraded_control.h), when a declared null setting is the control or differs from it
// (naming the first differing field, as settings.field.path), or when the
// design cannot take one of `counts` participants (resized_protocol with
// `seed`).
PlanDesign check_plan_design(const protocols::Protocol& protocol, const std::string& protocol_path,
                             const std::vector<int>& counts, std::uint64_t seed, const SimulatedStudyOptions& sim);

}  // namespace hapticlab::planning
