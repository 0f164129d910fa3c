#include "core/common/clock.h"

#include <ctime>

namespace hapticlab {

void WallClock::sleep_until(double t_s) noexcept {
  const double sleep_to_s = t_s - kSpinMargin_s;
  if (now_s() < sleep_to_s) {
    const auto deadline =
        start_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                     std::chrono::duration<double>(sleep_to_s));
    const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                        deadline.time_since_epoch())
                        .count();
    timespec ts{static_cast<time_t>(ns / 1'000'000'000), static_cast<long>(ns % 1'000'000'000)};
    // steady_clock is CLOCK_MONOTONIC on Linux/glibc, so an absolute sleep on
    // that clock wakes at the right instant even after signal interruptions.
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) != 0) {
    }
  }
  while (now_s() < t_s) {
  }
}

}  // namespace hapticlab
