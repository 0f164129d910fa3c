#include "analysis/stats/correlation.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "analysis/stats/data_error.h"
#include "analysis/stats/distributions.h"

namespace hapticlab::analysis {

std::string_view correlation_strength_name(CorrelationStrength strength) {
  switch (strength) {
    case CorrelationStrength::kNone: return "none";
    case CorrelationStrength::kWeak: return "weak";
    case CorrelationStrength::kStrong: return "strong";
  }
  return "none";
}

CorrelationStrength classify_correlation(double r) {
  const double a = std::fabs(r);
  if (a >= 0.7) return CorrelationStrength::kStrong;
  if (a >= 0.3) return CorrelationStrength::kWeak;
  return CorrelationStrength::kNone;
}

CorrelationResult pearson_correlation(std::span<const double> x, std::span<const double> y) {
  if (x.size() != y.size()) {
    throw DataError("pearson_correlation(): x has " + std::to_string(x.size()) +
                    " values but y has " + std::to_string(y.size()));
  }
  const std::size_t n = x.size();
  if (n < 3) {
    throw DataError("pearson_correlation(): " + std::to_string(n) +
                    " pairs; at least 3 are needed for a p-value");
  }
  // Two passes (means first) keep the sums of squares accurate for data
  // with a large offset, e.g. trial start times.
  double mean_x = 0.0;
  double mean_y = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(x[i]) || !std::isfinite(y[i])) {
      throw DataError("pearson_correlation(): pair " + std::to_string(i + 1) +
                      " holds a non-finite value");
    }
    mean_x += x[i];
    mean_y += y[i];
  }
  mean_x /= static_cast<double>(n);
  mean_y /= static_cast<double>(n);
  double sxx = 0.0;
  double syy = 0.0;
  double sxy = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double dx = x[i] - mean_x;
    const double dy = y[i] - mean_y;
    sxx += dx * dx;
    syy += dy * dy;
    sxy += dx * dy;
  }
  if (sxx == 0.0 || syy == 0.0) {
    throw DataError(std::string("pearson_correlation(): ") + (sxx == 0.0 ? "x" : "y") +
                    " is constant; the correlation is undefined");
  }
  CorrelationResult result;
  result.n = n;
  result.df = static_cast<double>(n - 2);
  result.r = std::clamp(sxy / std::sqrt(sxx * syy), -1.0, 1.0);
  const double one_minus_r2 = 1.0 - result.r * result.r;
  if (one_minus_r2 <= 0.0) {
    result.t = std::copysign(std::numeric_limits<double>::infinity(), result.r);
    result.p = 0.0;
  } else {
    result.t = result.r * std::sqrt(result.df / one_minus_r2);
    result.p = student_t_two_sided(result.t, result.df);
  }
  result.strength = classify_correlation(result.r);
  return result;
}

}  // namespace hapticlab::analysis
