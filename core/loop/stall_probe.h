#pragma once
// StallProbe: how often the machine itself takes the CPU away from a running
// thread, measured the way the haptic loop would notice it. A thread spins
// reading the clock; wherever two successive reads lie more than a threshold
// apart, the thread was not running (preempted by another thread, an
// interrupt, or on a virtual machine the host descheduling the vCPU).
//
// The result is the share of 1 ms windows holding such a stall: a 1 kHz loop
// cannot have a p99 period jitter below the threshold if more than 1 % of
// the windows do, whatever its own code does. `hapticlab bench loop` runs it
// before the loop, so a jitter figure comes with the machine's own.
//
// Not thread-safe; feed one thread's reads.

#include <cstdint>

namespace hapticlab {

struct StallProbeResult {
  std::uint64_t windows = 0;              // complete 1 ms windows seen
  std::uint64_t windows_with_stall = 0;   // ... in which a stall ended
  double max_stall_s = 0.0;               // longest gap between two reads
  double stalled_fraction() const noexcept {
    return windows == 0 ? 0.0 : static_cast<double>(windows_with_stall) / static_cast<double>(windows);
  }
};

class StallCounter {
 public:
  static constexpr double kWindow_s = 1e-3;
  // threshold_s > 0: a gap longer than this between two reads is a stall.
  explicit StallCounter(double threshold_s) noexcept : threshold_s_(threshold_s) {}
  // One clock read [s], non-decreasing. A stall counts in the window where
  // it ends; a stall spanning several windows counts once.
  void add(double t_s) noexcept;
  // Windows completed so far (the one in progress is left out).
  const StallProbeResult& result() const noexcept { return result_; }

 private:
  double threshold_s_;
  StallProbeResult result_;
  bool started_ = false;
  double last_s_ = 0.0;
  std::int64_t window_ = 0;
  bool window_stalled_ = false;
};

// Spins on std::chrono::steady_clock for duration_s (> 0) on the calling
// thread and returns the counts with a 100 µs threshold unless told otherwise.
StallProbeResult probe_stalls(double duration_s, double threshold_s = 100e-6);

}  // namespace hapticlab
