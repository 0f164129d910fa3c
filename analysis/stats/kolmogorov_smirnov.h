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
#include <cstddef>
#include <span>

namespace hapticlab::analysis {

struct KsResult {
  double d = 0.0;  // in [0, 1]
  double p = 1.0;  // asymptotic, two-sided
  std::size_t n1 = 0;
  std::size_t n2 = 0;
};

// a, b: non-empty, finite (not checked), any order. Ties between the samples
// are handled: both distribution functions step at a shared value before the
// gap is measured.
double ks_statistic(std::span<const double> a, std::span<const double> b);

// Same, for samples already sorted ascending (not checked); no allocation.
double ks_statistic_sorted(std::span<const double> a, std::span<const double> b);

// D and its asymptotic p-value. Throws DataError for an empty or non-finite
// sample.
KsResult ks_test(std::span<const double> a, std::span<const double> b);

}  // namespace hapticlab::analysis
