#pragma once
// The protocol's optional "safety" object (docs/safety.md, docs/protocols.md):
// force limits the operator sets below the device's own ratings, for every
// trial of the study.
//
//   "safety": {
//     "peak_force_fraction": 0.5,        // of each joint's peak output, 0..1
//     "max_insertion_force_N": 8.0,      // 0..1000
//     "max_pitch_yaw_torque_Nm": 0.4,    // 0..100, pitch and yaw
//     "max_twist_torque_Nm": 0.05,       // 0..100
//     "max_grip_torque_Nm": 0.2          // 0..100
//   }
//
// Every field is optional; each can only lower what the device allows (a
// value above the device's peak has no effect). Unknown fields are errors.

#include <string>
#include <string_view>

#include <nlohmann/json_fwd.hpp>

#include "core/loop/force_guard.h"

namespace hapticlab::protocols {

// Throws ProtocolError naming "safety.<field>", the value and the range.
OperatorForceLimits safety_from_json(const nlohmann::json& v, const std::string& source);

// The "safety" object of a protocol text that was validated when the study
// was created (a study database stores it byte for byte); the defaults
// when there is none.
OperatorForceLimits safety_from_protocol_text(std::string_view protocol_json, const std::string& source);

}  // namespace hapticlab::protocols
