#pragma once
// The events of the console's live streams (server-sent events): a status
// with the plots' points that its reader has not had yet.

#include <algorithm>
#include <array>
#include <cstddef>
#include <string>

#include <nlohmann/json.hpp>

#include "console/live_buffer.h"

namespace hapticlab::console {

// The state of a live stream's sender: what it has sent of the present
// trial (or free-trial repetition), so each event carries only new points.
struct LiveCursor {
  std::array<double, 2> last_t_s{-1.0, -1.0};
  int repetition = -1;
};

// One event of a live stream: the status and the points after `cursor`.
// `points_of(after_t_s)`: each instrument's points with loop time > after_t_s.
template <typename PointsOf>
nlohmann::json live_event(const nlohmann::json& status, const char* repetition_key, PointsOf points_of,
                          LiveCursor& cursor) {
  const int repetition = status.value(repetition_key, 0);
  if (repetition != cursor.repetition) cursor = LiveCursor{{-1.0, -1.0}, repetition};
  const auto points = points_of(std::min(cursor.last_t_s[0], cursor.last_t_s[1]));
  nlohmann::json j = {{"status", status}, {"instruments", nlohmann::json::array()}};
  for (std::size_t k = 0; k < 2; ++k) {
    nlohmann::json series = nlohmann::json::array();
    for (const LivePoint& p : points[k]) {
      if (p.t_s <= cursor.last_t_s[k]) continue;
      series.push_back({p.t_s, p.tip_force_N, p.displayed_force_N, p.insertion_m, p.pitch_rad, p.yaw_rad});
      cursor.last_t_s[k] = p.t_s;
    }
    j["instruments"].push_back(series);
  }
  return j;
}

// A server-sent event named `event` carrying `data` as JSON (invalid UTF-8
// replaced).
std::string sse(const char* event, const nlohmann::json& data);

}  // namespace hapticlab::console
