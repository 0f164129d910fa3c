#pragma once
// The JSON answer of a console route, its text with invalid UTF-8 replaced
// (a name from the study database never makes an answer fail).

#include <nlohmann/json.hpp>

#include "console/http/http_response.h"

namespace hapticlab::console {

inline http::Response json_reply(const nlohmann::json& j, int status = 200) {
  http::Response r;
  r.status = status;
  r.body = j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  return r;
}

}  // namespace hapticlab::console
