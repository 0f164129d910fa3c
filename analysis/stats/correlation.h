#pragma once
// Pearson's product-moment correlation with its two-sided p-value, and the
// thesis' reading of |r| (3.4.2.2, Table 3.7): |r| >= 0.7 strong,
// 0.3 <= |r| < 0.7 weak, below 0.3 little or none.
//
//   r = Σ(x − x̄)(y − ȳ) / sqrt(Σ(x − x̄)² Σ(y − ȳ)²)
//   t = r·sqrt((n − 2)/(1 − r²)),  p = P(|T| >= |t|), T ~ Student's t(n − 2)
#include <cstddef>
#include <span>
#include <string_view>

namespace hapticlab::analysis {

enum class CorrelationStrength { kNone, kWeak, kStrong };

// "none", "weak", "strong".
std::string_view correlation_strength_name(CorrelationStrength strength);
CorrelationStrength classify_correlation(double r);

struct CorrelationResult {
  double r = 0.0;   // in [-1, 1]
  double t = 0.0;   // infinite when |r| == 1
  double df = 0.0;  // n − 2
  double p = 1.0;   // two-sided, 0 when |r| == 1
  std::size_t n = 0;
  CorrelationStrength strength = CorrelationStrength::kNone;
};

// x, y: same length n >= 3, finite, neither constant. Throws DataError,
// naming the variables by x_name and y_name (e.g. the CSV columns).
//
// "Constant" allows for rounding: a spread no larger than the error of the
// mean itself, sd <= 4·(n + 1)·ε·max|v|, is noise (0.1, 0.1, 0.1 has a mean
// of 0.10000000000000002, and Σ(x − x̄)² = 6e-34 rather than 0), and r and p
// computed from it would be meaningless (r = 0, p = 1, say).
CorrelationResult pearson_correlation(std::span<const double> x, std::span<const double> y,
                                      std::string_view x_name = "x",
                                      std::string_view y_name = "y");

}  // namespace hapticlab::analysis
