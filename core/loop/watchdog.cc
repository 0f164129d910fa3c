#include "core/loop/watchdog.h"

#include <algorithm>
#include <chrono>

namespace hapticlab {

Watchdog::Watchdog(const std::atomic<std::uint64_t>& heartbeat, Device& device, double timeout_s,
                   const std::atomic<DeviceCall>* call, double read_allowance_s) noexcept
    : heartbeat_(heartbeat),
      device_(device),
      timeout_s_(timeout_s),
      call_(call),
      read_allowance_s_(read_allowance_s > 0.0 ? read_allowance_s : 0.0) {}

Watchdog::~Watchdog() { stop(); }

void Watchdog::start() {
  stop();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = false;
  }
  tripped_.store(false, std::memory_order_release);
  stalled_for_s_.store(0.0, std::memory_order_release);
  tripped_call_.store(DeviceCall::kNone, std::memory_order_release);
  tripped_limit_s_.store(0.0, std::memory_order_release);
  shutdown_since_ns_.store(0, std::memory_order_release);
  shutdown_tripped_.store(false, std::memory_order_release);
  armed_.store(true, std::memory_order_release);
  thread_ = std::thread([this] { watch(); });
}

void Watchdog::stop() noexcept {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void Watchdog::watch_shutdown(double limit_s) noexcept {
  shutdown_limit_s_.store(limit_s, std::memory_order_release);
  const auto now = std::chrono::steady_clock::now().time_since_epoch();
  shutdown_since_ns_.store(std::max<std::int64_t>(1, std::chrono::duration_cast<std::chrono::nanoseconds>(now).count()),
                           std::memory_order_release);
  armed_.store(true, std::memory_order_release);
}

void Watchdog::watch() {
  using Steady = std::chrono::steady_clock;
  const auto timeout = std::chrono::duration<double>(timeout_s_);
  const auto reading_timeout = std::chrono::duration<double>(timeout_s_ + read_allowance_s_);
  const auto poll = std::max<Steady::duration>(std::chrono::duration_cast<Steady::duration>(timeout / 4),
                                               std::chrono::milliseconds(1));
  std::uint64_t last_beat = heartbeat_.load(std::memory_order_relaxed);
  Steady::time_point last_change = Steady::now();

  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    wake_.wait_for(lock, poll, [this] { return stopping_; });
    if (stopping_) break;
    const std::uint64_t beat = heartbeat_.load(std::memory_order_relaxed);
    const Steady::time_point now = Steady::now();
    const std::int64_t shutdown_ns = shutdown_since_ns_.load(std::memory_order_acquire);
    if (beat != last_beat && shutdown_ns == 0) {
      last_beat = beat;
      last_change = now;
      continue;
    }
    const DeviceCall in_call = call_ != nullptr ? call_->load(std::memory_order_acquire) : DeviceCall::kNone;
    std::chrono::duration<double> quiet = now - last_change;
    std::chrono::duration<double> limit = in_call == DeviceCall::kRead ? reading_timeout : timeout;
    if (shutdown_ns != 0) {  // the last calls, timed from their start
      quiet = now - Steady::time_point(std::chrono::duration_cast<Steady::duration>(std::chrono::nanoseconds(shutdown_ns)));
      limit = std::chrono::duration<double>(shutdown_limit_s_.load(std::memory_order_acquire));
    }
    if (quiet > limit && armed_.exchange(false, std::memory_order_acq_rel)) {
      // Cut the force first; the loop reads the flag when it comes back.
      device_.halt();
      tripped_call_.store(in_call, std::memory_order_release);
      tripped_limit_s_.store(limit.count(), std::memory_order_release);
      stalled_for_s_.store(quiet.count(), std::memory_order_release);
      if (shutdown_ns != 0) shutdown_tripped_.store(true, std::memory_order_release);
      tripped_.store(true, std::memory_order_release);
    }
  }
}

}  // namespace hapticlab
