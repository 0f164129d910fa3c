#include "analysis/stats/sign_flip.h"

#include <cmath>
#include <string>

#include "analysis/stats/data_error.h"
#include "analysis/stats/split_mix64.h"

namespace hapticlab::analysis {

SignFlipResult sign_flip_test(std::span<const double> d, std::uint64_t seed) {
  const std::size_t n = d.size();
  if (n == 0) throw DataError("sign-flip test: no differences");
  double observed = 0.0;
  double scale = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(d[i])) throw DataError("sign-flip test: difference " + std::to_string(i) + " is not finite");
    observed += d[i];
    scale += std::fabs(d[i]);
  }
  // A pattern's sum equal to the observed one up to rounding counts as
  // "at least as extreme" (it is the same sum added in another order).
  const double target = std::fabs(observed) - 1e-12 * scale;
  SignFlipResult r;
  r.n = n;
  r.mean = observed / static_cast<double>(n);
  if (n <= 24) {
    const std::uint64_t patterns = std::uint64_t{1} << n;
    std::uint64_t extreme = 0;
    for (std::uint64_t mask = 0; mask < patterns; ++mask) {
      double sum = 0.0;
      for (std::size_t i = 0; i < n; ++i) sum += (mask >> i) & 1u ? -d[i] : d[i];
      if (std::fabs(sum) >= target) ++extreme;
    }
    r.p = static_cast<double>(extreme) / static_cast<double>(patterns);
    return r;
  }
  SplitMix64 rng(seed);
  constexpr std::uint64_t kDraws = std::uint64_t{1} << 20;
  std::uint64_t extreme = 0;
  for (std::uint64_t k = 0; k < kDraws; ++k) {
    double sum = 0.0;
    std::uint64_t bits = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (i % 64 == 0) bits = rng.next();
      sum += (bits >> (i % 64)) & 1u ? -d[i] : d[i];
    }
    if (std::fabs(sum) >= target) ++extreme;
  }
  r.exact = false;
  r.p = static_cast<double>(extreme + 1) / static_cast<double>(kDraws + 1);
  return r;
}

double sign_flip_smallest_p(std::size_t n) {
  if (n == 0) return 1.0;
  if (n <= 24) return 2.0 / static_cast<double>(std::uint64_t{1} << n);
  return 1.0 / static_cast<double>((std::uint64_t{1} << 20) + 1);
}

std::size_t sign_flip_differences_needed(double level) {
  for (std::size_t n = 1; n <= 25; ++n)
    if (sign_flip_smallest_p(n) < level) return n;
  return 0;
}

}  // namespace hapticlab::analysis
