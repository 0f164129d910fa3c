#pragma once
// Ctrl-C (SIGINT) and SIGTERM as a flag a long command polls, so a running
// trial is closed properly (aborted, re-queued, its samples kept) instead
// of the process dying mid-write. A second Ctrl-C (a second or more after
// the first) kills at once, for an operator who really means it; the
// database survives that too.

#include <atomic>

namespace hapticlab::app {

class InterruptFlag {
 public:
  InterruptFlag();   // installs the handlers (one instance at a time)
  ~InterruptFlag();  // restores the previous handlers
  InterruptFlag(const InterruptFlag&) = delete;
  InterruptFlag& operator=(const InterruptFlag&) = delete;

  const std::atomic<bool>& flag() const noexcept;
  bool raised() const noexcept { return flag().load(std::memory_order_relaxed); }
};

}  // namespace hapticlab::app
