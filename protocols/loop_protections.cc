#include "protocols/loop_protections.h"

#include "protocols/protocol_json.h"
#include "protocols/safety_json.h"

namespace hapticlab::protocols {

LoopSafetyConfig loop_protections(const Protocol& protocol) {
  LoopSafetyConfig c;
  c.force_limits = protocol.safety;
  c.rate.tolerance_fraction = protocol.rate_tolerance_fraction;
  return c;
}

LoopSafetyConfig loop_protections_from_protocol_text(std::string_view protocol_json, const std::string& source) {
  LoopSafetyConfig c;
  c.force_limits = safety_from_protocol_text(protocol_json, source);
  c.rate.tolerance_fraction = rate_tolerance_from_protocol_text(protocol_json, source);
  return c;
}

}  // namespace hapticlab::protocols
