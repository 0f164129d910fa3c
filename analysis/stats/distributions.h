#pragma once
// Upper-tail probabilities used by the tests. Chi-square and Student's t come
// from Boost.Math; the Kolmogorov limiting distribution (not in Boost 1.74) is
// summed here.
namespace hapticlab::analysis {

// P(X >= x) for X ~ chi-square(df); x >= 0, df > 0. Returns 1 for x <= 0.
double chi_squared_upper(double x, double df);

// Two-sided P(|T| >= |t|) for T ~ Student's t(df); df > 0. 0 for infinite t.
double student_t_two_sided(double t, double df);

// P(F >= f) for F ~ F(df1, df2). Returns 1 for f <= 0, 0 for infinite f.
double f_upper(double f, double df1, double df2);

// Q(λ) = P(K > λ) for Kolmogorov's limiting distribution,
// Q(λ) = 2 Σ_{j≥1} (−1)^{j−1} exp(−2 j² λ²). λ >= 0; Q(0) = 1.
double kolmogorov_upper(double lambda);

}  // namespace hapticlab::analysis
