#pragma once
// The operator's STOP (POST /api/session/stop): it stops whatever drives
// the device at once, on the server's loop thread, then stores what it
// stopped and answers (docs/console.md).

#include <chrono>
#include <cstddef>
#include <functional>
#include <optional>

#include "console/console_session.h"
#include "console/console_tuning.h"
#include "console/http/http_server.h"

namespace hapticlab::console {

// STOP is answered within this of its head, stored or not (its record is
// written on a connection of its own, which another's lock can hold up).
inline constexpr auto kStopAnswerWithin = std::chrono::milliseconds(50);

// The route. `token_check` (the operator's token) runs first; a body of
// up to `max_body_bytes` is read after STOP has acted. `session` and
// `tuning` must outlive the server the route is added to.
http::Route stop_route(ConsoleSession& session, ConsoleTuning& tuning,
                       std::function<std::optional<http::Response>(http::Request&)> token_check,
                       std::size_t max_body_bytes);

}  // namespace hapticlab::console
