#include "analysis/stats/distributions.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/fisher_f.hpp>
#include <boost/math/distributions/students_t.hpp>

namespace hapticlab::analysis {

double chi_squared_upper(double x, double df) {
  if (!(x > 0.0)) return 1.0;
  if (std::isinf(x)) return 0.0;
  return boost::math::cdf(boost::math::complement(boost::math::chi_squared(df), x));
}

double student_t_two_sided(double t, double df) {
  if (std::isinf(t)) return 0.0;
  const double tail =
      boost::math::cdf(boost::math::complement(boost::math::students_t(df), std::fabs(t)));
  return std::min(1.0, 2.0 * tail);
}

double f_upper(double f, double df1, double df2) {
  if (!(f > 0.0)) return 1.0;
  if (std::isinf(f)) return 0.0;
  return boost::math::cdf(boost::math::complement(boost::math::fisher_f(df1, df2), f));
}

double kolmogorov_upper(double lambda) {
  if (!(lambda > 0.0)) return 1.0;
  constexpr double kPi = std::numbers::pi;
  if (lambda < 1.0) {
    // The alternating series converges slowly for small λ; use the Jacobi
    // theta form P(K <= λ) = sqrt(2π)/λ Σ_{j≥1} exp(−(2j−1)² π² / (8 λ²)).
    double sum = 0.0;
    for (int j = 1; j <= 50; ++j) {
      const double odd = 2.0 * j - 1.0;
      const double term = std::exp(-odd * odd * kPi * kPi / (8.0 * lambda * lambda));
      sum += term;
      if (term < 1e-17 * sum) break;
    }
    return std::clamp(1.0 - std::sqrt(2.0 * kPi) / lambda * sum, 0.0, 1.0);
  }
  double sum = 0.0;
  double sign = 1.0;
  for (int j = 1; j <= 100; ++j) {
    const double term = std::exp(-2.0 * j * j * lambda * lambda);
    sum += sign * term;
    if (term < 1e-17) break;
    sign = -sign;
  }
  return std::clamp(2.0 * sum, 0.0, 1.0);
}

}  // namespace hapticlab::analysis
