#include "console/live_buffer.h"

#include <cmath>

namespace hapticlab::console {
namespace {

float norm(const Vec3& v) { return static_cast<float>(std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])); }

}  // namespace

void LiveBuffer::clear() {
  points_ = {};
  next_t_s_ = {0.0, 0.0};
  newest_t_s_ = 0.0;
}

void LiveBuffer::add(std::span<const LoopSample> batch) {
  for (const LoopSample& s : batch) {
    newest_t_s_ = s.t_s;
    for (std::size_t k = 0; k < 2; ++k) {
      if (s.t_s < next_t_s_[k]) continue;
      next_t_s_[k] = s.t_s + step_s_;
      const InstrumentSample& v = s.instrument[k];
      points_[k].push_back({s.t_s, norm(v.ve_force_N), norm(v.displayed_force_N),
                            static_cast<float>(v.degraded_position[0]), static_cast<float>(v.degraded_position[1]),
                            static_cast<float>(v.degraded_position[2])});
      while (!points_[k].empty() && points_[k].front().t_s < s.t_s - window_s_) points_[k].pop_front();
    }
  }
}

std::array<std::vector<LivePoint>, 2> LiveBuffer::since(double after_t_s) const {
  std::array<std::vector<LivePoint>, 2> out;
  for (std::size_t k = 0; k < 2; ++k)
    for (const LivePoint& p : points_[k])
      if (p.t_s > after_t_s) out[k].push_back(p);
  return out;
}

}  // namespace hapticlab::console
