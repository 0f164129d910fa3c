// One walk up a resample's rank histograms giving two Kolmogorov–Smirnov
// statistics at once, the inner loop of the KS block bootstrap (Appendix I).
#pragma once

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>

namespace hapticlab::analysis {

struct KsPairD {
  double d12 = 0.0;  // sup |F1 − F2|
  double d13 = 0.0;  // sup |F1 − F3|
};

// count1..count3 hold, per rank 0..levels-1, how often each of three samples
// of sizes n1, n2, n3 (each >= 1) took that rank, and bit u % 64 of
// touched[u / 64] is set where any of them is not zero (more bits may be
// set). The walk returns the two statistics and leaves the histograms and
// the bits zeroed for the next resample. It visits only the touched ranks,
// word by word: a participant's series have many more distinct values (the
// ranks) than one resample takes.
//
// The result is, bit for bit, the maximum over distinct ranks of
// |double(c1)/n1 − double(c2)/n2| (ks_statistic_sorted's arithmetic), but
// without three divisions per rank: the gap is compared exactly in integers,
// |c1·n2 − c2·n1| in units of 1/(n1·n2), and the doubles are computed only
// where that gap reaches its running maximum. Distinct exact gaps differ by
// at least 1/(n1·n2), far more than the three roundings (under 1e-15) can
// move them while n1·n2 < 2^40, so only ranks with the largest exact gap can
// give the largest rounded one; among those the rounded values may still
// differ by an ulp, and the largest is kept. Larger samples take the plain
// division path.
inline KsPairD ks_rank_walk(std::span<std::uint32_t> count1, std::span<std::uint32_t> count2,
                            std::span<std::uint32_t> count3, std::span<std::uint64_t> touched,
                            std::size_t levels, std::size_t n1, std::size_t n2, std::size_t n3) {
  const double n1_d = static_cast<double>(n1);
  const double n2_d = static_cast<double>(n2);
  const double n3_d = static_cast<double>(n3);
  constexpr std::uint64_t kExactLimit = std::uint64_t{1} << 40;
  const bool exact = static_cast<std::uint64_t>(n1) * n2 < kExactLimit &&
                     static_cast<std::uint64_t>(n1) * n3 < kExactLimit;
  std::int64_t c1 = 0;
  std::int64_t c2 = 0;
  std::int64_t c3 = 0;
  std::int64_t best12 = 0;
  std::int64_t best13 = 0;
  KsPairD d;
  const auto n1_i = static_cast<std::int64_t>(n1);
  const auto n2_i = static_cast<std::int64_t>(n2);
  const auto n3_i = static_cast<std::int64_t>(n3);
  const std::size_t words = (levels + 63) / 64;
  for (std::size_t w = 0; w < words; ++w) {
    for (std::uint64_t bits = touched[w]; bits != 0; bits &= bits - 1) {
      const std::size_t u = w * 64 + static_cast<std::size_t>(std::countr_zero(bits));
      if ((count1[u] | count2[u] | count3[u]) == 0) continue;
      c1 += count1[u];
      c2 += count2[u];
      c3 += count3[u];
      count1[u] = count2[u] = count3[u] = 0;
      if (!exact) {
        const double f1 = static_cast<double>(c1) / n1_d;
        d.d12 = std::max(d.d12, std::fabs(f1 - static_cast<double>(c2) / n2_d));
        d.d13 = std::max(d.d13, std::fabs(f1 - static_cast<double>(c3) / n3_d));
        continue;
      }
      const std::int64_t gap12 = std::abs(c1 * n2_i - c2 * n1_i);
      const std::int64_t gap13 = std::abs(c1 * n3_i - c3 * n1_i);
      if (gap12 < best12 && gap13 < best13) continue;
      const double f1 = static_cast<double>(c1) / n1_d;
      if (gap12 >= best12) {
        const double v = std::fabs(f1 - static_cast<double>(c2) / n2_d);
        d.d12 = gap12 > best12 ? v : std::max(d.d12, v);
        best12 = gap12;
      }
      if (gap13 >= best13) {
        const double v = std::fabs(f1 - static_cast<double>(c3) / n3_d);
        d.d13 = gap13 > best13 ? v : std::max(d.d13, v);
        best13 = gap13;
      }
    }
    touched[w] = 0;
  }
  return d;
}

}  // namespace hapticlab::analysis
