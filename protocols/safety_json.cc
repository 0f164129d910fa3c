#include "protocols/safety_json.h"

#include <nlohmann/json.hpp>

#include "protocols/protocol_error.h"
#include "protocols/shown_json.h"

namespace hapticlab::protocols {
namespace {

using nlohmann::json;

struct Field {
  const char* name;
  double OperatorForceLimits::*member;
  double max;
};

// Upper bounds as for the settings' device_limits: far above any haptic
// device, so they only catch a unit slip (mN for N).
constexpr Field kFields[] = {
    {"peak_force_fraction", &OperatorForceLimits::peak_force_fraction, 1.0},
    {"max_insertion_force_N", &OperatorForceLimits::insertion_force_N, 1000.0},
    {"max_pitch_yaw_torque_Nm", &OperatorForceLimits::pitch_yaw_torque_Nm, 100.0},
    {"max_twist_torque_Nm", &OperatorForceLimits::twist_torque_Nm, 100.0},
    {"max_grip_torque_Nm", &OperatorForceLimits::grip_torque_Nm, 100.0},
};

std::string number_text(double x) {
  std::string s = json(x).dump();
  return s;
}

}  // namespace

OperatorForceLimits safety_from_json(const json& v, const std::string& source) {
  if (!v.is_object()) throw ProtocolError(source, "safety", "is " + shown(v) + ", but must be an object");
  OperatorForceLimits limits;
  for (const auto& [key, value] : v.items()) {
    const Field* field = nullptr;
    for (const Field& f : kFields)
      if (key == f.name) field = &f;
    if (field == nullptr) {
      std::string allowed;
      for (const Field& f : kFields) allowed += (allowed.empty() ? "" : ", ") + std::string(f.name);
      throw ProtocolError(source, "safety." + key, "is not a known field; allowed here: " + allowed);
    }
    const std::string rule = "must be a number >= 0 and <= " + number_text(field->max);
    if (!value.is_number()) throw ProtocolError(source, "safety." + key, "is " + shown(value) + ", but " + rule);
    const double x = value.get<double>();
    if (!(x >= 0.0 && x <= field->max))
      throw ProtocolError(source, "safety." + key, "is " + shown(value) + ", but " + rule);
    limits.*(field->member) = x;
  }
  return limits;
}

OperatorForceLimits safety_from_protocol_text(std::string_view protocol_json, const std::string& source) {
  const json j = json::parse(protocol_json);
  const auto it = j.find("safety");
  return it == j.end() ? OperatorForceLimits{} : safety_from_json(*it, source);
}

}  // namespace hapticlab::protocols
