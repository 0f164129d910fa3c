#include "analysis/stats/correlation.h"

#include <algorithm>
#include <cmath>
#include <tuple>
#include <limits>
#include <string>

#include "analysis/stats/data_error.h"
#include "analysis/stats/distributions.h"
#include "core/common/csv_format.h"

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

namespace {

// Within rounding error of a constant; see the header.
bool is_constant(std::span<const double> v, double sum_of_squares) {
  double scale = 0.0;
  for (double e : v) scale = std::max(scale, std::fabs(e));
  const double n = static_cast<double>(v.size());
  const double noise_sd = 4.0 * (n + 1.0) * std::numeric_limits<double>::epsilon() * scale;
  return std::sqrt(sum_of_squares / n) <= noise_sd;
}

// Sums of squares and products of the deviations, each variable's divided
// by its largest |deviation| (0 for a constant variable).
std::tuple<double, double, double> scaled_sums(std::span<const double> x, std::span<const double> y, double mean_x,
                                               double mean_y) {
  double scale_x = 0.0;
  double scale_y = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    scale_x = std::max(scale_x, std::fabs(x[i] - mean_x));
    scale_y = std::max(scale_y, std::fabs(y[i] - mean_y));
  }
  if (scale_x == 0.0 || scale_y == 0.0) return {scale_x, scale_y, 0.0};
  double sxx = 0.0;
  double syy = 0.0;
  double sxy = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double dx = (x[i] - mean_x) / scale_x;
    const double dy = (y[i] - mean_y) / scale_y;
    sxx += dx * dx;
    syy += dy * dy;
    sxy += dx * dy;
  }
  return {sxx, syy, sxy};
}

}  // namespace

CorrelationResult pearson_correlation(std::span<const double> x, std::span<const double> y,
                                      std::string_view x_name, std::string_view y_name) {
  const std::string names = "Pearson correlation of " + std::string(x_name) + " and " +
                            std::string(y_name) + ": ";
  if (x.size() != y.size()) {
    throw DataError(names + std::string(x_name) + " has " + std::to_string(x.size()) +
                    " values but " + std::string(y_name) + " has " + std::to_string(y.size()));
  }
  const std::size_t n = x.size();
  if (n < 3) {
    throw DataError(names + std::to_string(n) + " pair(s); at least 3 are needed for a p-value");
  }
  // Two passes (means first) keep the sums of squares accurate for data
  // with a large offset, e.g. trial start times.
  double mean_x = 0.0;
  double mean_y = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(x[i]) || !std::isfinite(y[i])) {
      throw DataError(names + "pair " + std::to_string(i + 1) + " holds a non-finite value");
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
  // Squares of deviations beyond about 1e154 overflow and below about
  // 1e-154 underflow (r = 0 for values of 1e155, "constant" for 1e-200):
  // then the sums again, each variable's deviations divided by their
  // largest, which leaves r as it is. Ordinary data keeps its sums, bit
  // for bit.
  const double product = sxx * syy;
  if (!std::isfinite(product) || product < std::numeric_limits<double>::min()) {
    for (const auto& [v, mean, name] : {std::tuple{x, mean_x, x_name}, std::tuple{y, mean_y, y_name}}) {
      // is_constant's rule with the largest deviation for the RMS one.
      double largest = 0.0;
      double scale = 0.0;
      for (double e : v) {
        largest = std::max(largest, std::fabs(e - mean));
        scale = std::max(scale, std::fabs(e));
      }
      if (largest <= 4.0 * (static_cast<double>(n) + 1.0) * std::numeric_limits<double>::epsilon() * scale)
        throw DataError(names + std::string(name) + " is constant (every value equals " + format_number(v[0]) +
                        " to within rounding error); the correlation is undefined");
    }
    std::tie(sxx, syy, sxy) = scaled_sums(x, y, mean_x, mean_y);
  }
  for (const auto& [v, ss, name] : {std::tuple{x, sxx, x_name}, std::tuple{y, syy, y_name}}) {
    if (product >= std::numeric_limits<double>::min() && std::isfinite(product) && is_constant(v, ss)) {
      throw DataError(names + std::string(name) + " is constant (every value equals " +
                      format_number(v[0]) +
                      " to within rounding error); the correlation is undefined");
    }
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
