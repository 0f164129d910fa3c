#include "core/loop/loop_timing.h"

#include <algorithm>
#include <cmath>

namespace hapticlab {

LoopTimingStats::LoopTimingStats()
    : bins_(std::make_unique<std::atomic<std::uint64_t>[]>(kNumBins)) {}

void LoopTimingStats::record(double period_s, bool overrun) noexcept {
  // One writer: a relaxed load and store replace each read-modify-write,
  // whose locked instructions were a few percent of a simulated update.
  const auto bump = [](std::atomic<std::uint64_t>& a) {
    a.store(a.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  };
  if (!(period_s >= 0.0 && std::isfinite(period_s))) {
    bump(rejected_);
    return;
  }
  // Compare as double before converting: a huge period must not overflow the cast.
  const double bin = period_s / kBinWidth_s;
  const std::size_t index =
      bin < static_cast<double>(kNumRegularBins) ? static_cast<std::size_t>(bin) : kNumRegularBins;
  bump(bins_[index]);
  sum_s_.store(sum_s_.load(std::memory_order_relaxed) + period_s, std::memory_order_relaxed);
  if (period_s > max_s_.load(std::memory_order_relaxed)) {
    max_s_.store(period_s, std::memory_order_relaxed);
  }
  if (overrun) bump(overruns_);
  bump(count_);
}

double LoopTimingStats::percentile_s(double fraction, std::uint64_t total,
                                     double max_s) const noexcept {
  // Nearest rank: the smallest sample with at least `fraction` of all at or below it.
  const auto rank = std::max<std::uint64_t>(
      1, static_cast<std::uint64_t>(std::ceil(fraction * static_cast<double>(total))));
  std::uint64_t seen = 0;
  for (std::size_t k = 0; k < kNumRegularBins; ++k) {
    seen += bins_[k].load(std::memory_order_relaxed);
    // A bin centre can lie above the largest sample in it; the max is exact.
    if (seen >= rank) return std::min((static_cast<double>(k) + 0.5) * kBinWidth_s, max_s);
  }
  return max_s;  // the rank lies in the overflow bin
}

LoopTimingSummary LoopTimingStats::summary() const {
  LoopTimingSummary s;
  s.count = count_.load(std::memory_order_relaxed);
  s.overruns = overruns_.load(std::memory_order_relaxed);
  s.rejected = rejected_.load(std::memory_order_relaxed);
  s.max_period_s = max_s_.load(std::memory_order_relaxed);
  if (s.count > 0) s.mean_period_s = sum_s_.load(std::memory_order_relaxed) / static_cast<double>(s.count);

  // Percentiles rank within what the histogram holds now, which can differ
  // from `count` by the samples recorded during this scan.
  std::uint64_t total = 0;
  for (std::size_t k = 0; k < kNumBins; ++k) total += bins_[k].load(std::memory_order_relaxed);
  if (total > 0) {
    s.p50_period_s = percentile_s(0.50, total, s.max_period_s);
    s.p99_period_s = percentile_s(0.99, total, s.max_period_s);
  }
  return s;
}

void LoopTimingStats::reset() noexcept {
  for (std::size_t k = 0; k < kNumBins; ++k) bins_[k].store(0, std::memory_order_relaxed);
  count_.store(0, std::memory_order_relaxed);
  sum_s_.store(0.0, std::memory_order_relaxed);
  max_s_.store(0.0, std::memory_order_relaxed);
  overruns_.store(0, std::memory_order_relaxed);
  rejected_.store(0, std::memory_order_relaxed);
}

}  // namespace hapticlab
