#pragma once
// LoopTimingStats: how regular the haptic loop really ran — the distribution
// of its measured periods and how often it overran its deadline — recorded
// on the loop thread, read from any other.
//
// Periods go into a fixed histogram of 1 µs bins from 0 to 100 ms plus one
// overflow bin, allocated in the constructor, so record() is O(1), never
// allocates and never locks. Count, sum (for the mean), max and overruns
// are kept exactly; p50 and p99 are read from the histogram: the centre of
// the 1 µs bin holding the nearest-rank percentile (so within 0.5 µs of the
// exact sample), or the exact max when that rank lies in the overflow bin.
//
// Threads: record() from one thread (the loop); summary() from any thread
// while the loop runs. Every counter is a relaxed atomic, so there is no
// data race, but a summary taken mid-run is not one consistent snapshot: its
// percentiles may miss, or already include, the last few samples counted in
// `count`. reset() is meant for when the loop is not recording; racing with
// record() it may keep a sample or two of the old run.
//
// Not copyable or movable: the loop and its monitor hold references to it.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>

namespace hapticlab {

struct LoopTimingSummary {
  std::uint64_t count = 0;     // periods recorded
  double mean_period_s = 0.0;  // 0 when count == 0
  double p50_period_s = 0.0;   // median (bin centre, see above)
  double p99_period_s = 0.0;
  double max_period_s = 0.0;   // exact
  std::uint64_t overruns = 0;  // periods recorded with overrun = true
  std::uint64_t rejected = 0;  // non-finite or negative periods (not in the above)
};

class LoopTimingStats {
 public:
  static constexpr double kBinWidth_s = 1e-6;
  static constexpr std::size_t kNumRegularBins = 100'000;  // 0..100 ms

  LoopTimingStats();
  LoopTimingStats(const LoopTimingStats&) = delete;
  LoopTimingStats& operator=(const LoopTimingStats&) = delete;

  // Loop thread. `period_s` >= 0 and finite, else only `rejected` counts it.
  // `overrun`: the loop missed its deadline on this period.
  void record(double period_s, bool overrun) noexcept;

  // Any thread. O(number of bins), about 100 µs: call it from a monitor, not
  // from the loop.
  LoopTimingSummary summary() const;

  // Control thread, while the loop is not recording.
  void reset() noexcept;

 private:
  // Regular bins, then the overflow bin (>= 100 ms).
  static constexpr std::size_t kNumBins = kNumRegularBins + 1;

  double percentile_s(double fraction, std::uint64_t total, double max_s) const noexcept;

  std::unique_ptr<std::atomic<std::uint64_t>[]> bins_;
  std::atomic<std::uint64_t> count_{0};
  std::atomic<double> sum_s_{0.0};
  std::atomic<double> max_s_{0.0};
  std::atomic<std::uint64_t> overruns_{0};
  std::atomic<std::uint64_t> rejected_{0};
};

}  // namespace hapticlab
