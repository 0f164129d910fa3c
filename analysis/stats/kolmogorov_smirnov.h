#pragma once
// The two-sample Kolmogorov–Smirnov statistic (Smirnov 1939; thesis
// Appendix I): D = max over x of |F1(x) − F2(x)|, the largest vertical gap
// between the two empirical distribution functions, a dimensionless number
// in [0, 1].
//
// The asymptotic p-value is Smirnov's limit P(D >= d) ≈ Q(sqrt(n1·n2/(n1+n2))·d)
// with Q the Kolmogorov survival function, as R's ks.test(exact = FALSE)
// reports it. At the 5 % level this is the thesis' rule (1.4),
// D > 1.36·sqrt((n1 + n2)/(n1·n2)), meant for n1, n2 > 25; it does not
// account for temporally correlated samples (hence the block bootstrap).
//
// For small samples (n1·n2 < 10 000, R's default rule) the exact p is given
// instead, as R's ks.test does: under H0 every assignment of the pooled
// sorted values to the two samples is equally likely, i.e. every monotone
// lattice path from (0, 0) to (n1, n2), and P(D >= d) is the share of paths
// that reach |i/n1 − j/n2| >= d. With ties, as in R's psmirnov, the gap is
// only looked at where the pooled value changes (both ECDFs step together).
#include <cstddef>
#include <span>

namespace hapticlab::analysis {

struct KsResult {
  double d = 0.0;  // in [0, 1]
  double p = 1.0;  // two-sided: exact when `exact`, else asymptotic
  bool exact = false;
  double p_asymptotic = 1.0;  // always computed, for comparison
  std::size_t n1 = 0;
  std::size_t n2 = 0;
};

// a, b: non-empty, finite (not checked), any order. Ties between the samples
// are handled: both distribution functions step at a shared value before the
// gap is measured.
double ks_statistic(std::span<const double> a, std::span<const double> b);

// Same, for samples already sorted ascending (not checked); no allocation.
double ks_statistic_sorted(std::span<const double> a, std::span<const double> b);

// Below this n1·n2 the exact p is reported.
inline constexpr std::size_t kKsExactLimit = 10000;

// D and its p-value (exact when n1·n2 < kKsExactLimit). Throws DataError for
// an empty or non-finite sample.
KsResult ks_test(std::span<const double> a, std::span<const double> b);

// Exact two-sided P(D >= D observed) under H0, conditional on the ties of the
// pooled sample; a, b non-empty. Cost O(n1·n2) time, O(n2) memory.
double ks_exact_p(std::span<const double> a, std::span<const double> b);

}  // namespace hapticlab::analysis
