#include "analysis/stats/split_mix64.h"

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {

std::uint64_t SplitMix64::below(std::uint64_t bound) {
  if (bound == 0) throw DataError("SplitMix64::below(): bound must be >= 1");
  // (2⁶⁴ − bound) mod bound == 2⁶⁴ mod bound, computed without overflow
  const std::uint64_t threshold = (0 - bound) % bound;
  for (;;) {
    const std::uint64_t x = next();
    if (x >= threshold) return x % bound;
  }
}

}  // namespace hapticlab::analysis
