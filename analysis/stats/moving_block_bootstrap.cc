#include "analysis/stats/moving_block_bootstrap.h"

#include <algorithm>
#include <string>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {

void moving_block_resample(std::span<const double> series, std::size_t block_length,
                           SplitMix64& rng, std::vector<double>& out) {
  const std::size_t n = series.size();
  if (n == 0) throw DataError("block bootstrap: the series is empty");
  if (block_length < 1 || block_length > n) {
    throw DataError("block bootstrap: block length is " + std::to_string(block_length) +
                    ", but must be >= 1 and <= the series length " + std::to_string(n));
  }
  out.resize(n);
  const std::uint64_t starts = n - block_length + 1;
  std::size_t filled = 0;
  while (filled < n) {
    const auto start = static_cast<std::size_t>(rng.below(starts));
    const std::size_t take = std::min(block_length, n - filled);
    std::copy_n(series.begin() + static_cast<std::ptrdiff_t>(start), take,
                out.begin() + static_cast<std::ptrdiff_t>(filled));
    filled += take;
  }
}

}  // namespace hapticlab::analysis
