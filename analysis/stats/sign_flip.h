#pragma once
// The sign-flip permutation test for paired differences (Fisher 1935,
// Pitman 1937): under the null hypothesis each participant's difference is
// as likely positive as negative, so the observed sum is compared with the
// sums of every pattern of signs. Exact, needs no distribution, and its
// unit of evidence is whatever the differences are: here one per
// participant, so repetitions cannot count as independent evidence.
//
// With n differences the smallest two-sided p is 2 / 2^n: 0.25 with 3
// participants, 0.0078 with 8 — a Šidák level of 0.0073 cannot be reached
// with fewer than 9. That is the honest answer for a study of 3 surgeons.
#include <cstdint>
#include <span>

namespace hapticlab::analysis {

struct SignFlipResult {
  double p = 1.0;          // two-sided: P(|sum| >= |observed sum|)
  double mean = 0.0;       // mean difference
  std::size_t n = 0;       // differences used
  bool exact = true;       // all 2^n patterns; false: Monte Carlo (n > 24)
};

// Throws DataError for no differences or a non-finite one. For n > 24,
// 2^20 random patterns from `seed` (p then has a standard error below
// 0.0005) with the observed pattern counted, as Phipson & Smyth (2010) advise.
SignFlipResult sign_flip_test(std::span<const double> differences, std::uint64_t seed = 1);

// The smallest p sign_flip_test can give with n >= 1 differences: 2/2^n
// (every difference of one sign: the observed pattern and its mirror),
// 1/(2^20 + 1) beyond 24 (the observed pattern counted among the random
// ones). 1 for n = 0.
double sign_flip_smallest_p(std::size_t n);

// The fewest differences with which sign_flip_test can give p < level
// (what a comparison judged at `level` needs at least); 0 when no number
// of differences can (level <= 1/(2^20 + 1)).
std::size_t sign_flip_differences_needed(double level);

}  // namespace hapticlab::analysis
