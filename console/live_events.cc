#include "console/live_events.h"

namespace hapticlab::console {

std::string sse(const char* event, const nlohmann::json& data) {
  return std::string("event: ") + event + "\ndata: " +
         data.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n\n";
}

}  // namespace hapticlab::console
