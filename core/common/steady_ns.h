#pragma once
// The steady (monotonic) clock in nanoseconds, for deadlines on the
// real-time path: one integer, no allocation, no exception.

#include <chrono>
#include <cstdint>

namespace hapticlab {

inline std::int64_t steady_ns() noexcept {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace hapticlab
