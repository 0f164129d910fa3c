#include "analysis/stats/percentile.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {
namespace {

// Linear interpolation at 1-based fractional position h, clamped to [1, n].
double interpolate(std::span<const double> sorted, double h) {
  const double n = static_cast<double>(sorted.size());
  if (h <= 1.0) return sorted.front();
  if (h >= n) return sorted.back();
  const double lower = std::floor(h);
  const auto i = static_cast<std::size_t>(lower) - 1;  // 0-based index of the lower neighbour
  const double fraction = h - lower;
  return sorted[i] + fraction * (sorted[i + 1] - sorted[i]);
}

void check_p(double p_percent) {
  if (!(p_percent >= 0.0 && p_percent <= 100.0)) {
    throw DataError("percentile(): p is " + std::to_string(p_percent) +
                    ", but must be >= 0 and <= 100");
  }
}

}  // namespace

PercentileMethod parse_percentile_method(std::string_view name) {
  if (name == "matlab" || name == "r5") return PercentileMethod::kMatlab;
  if (name == "r7" || name == "numpy" || name == "excel") return PercentileMethod::kR7;
  if (name == "r6") return PercentileMethod::kR6;
  if (name == "nearest" || name == "nearest-rank") return PercentileMethod::kNearestRank;
  throw DataError("unknown percentile method '" + std::string(name) +
                  "'; expected one of: matlab (r5), r7 (numpy, excel), r6, nearest (nearest-rank)");
}

std::string_view percentile_method_name(PercentileMethod method) {
  switch (method) {
    case PercentileMethod::kMatlab: return "matlab";
    case PercentileMethod::kR7: return "r7";
    case PercentileMethod::kR6: return "r6";
    case PercentileMethod::kNearestRank: return "nearest";
  }
  return "matlab";
}

double percentile_sorted(std::span<const double> sorted, double p_percent, PercentileMethod method) {
  check_p(p_percent);
  if (sorted.empty()) throw DataError("percentile(): the sample is empty");
  const double n = static_cast<double>(sorted.size());
  switch (method) {
    case PercentileMethod::kMatlab:
      // x(i) at 100(i - 0.5)/n  <=>  i = n p/100 + 0.5
      return interpolate(sorted, n * p_percent / 100.0 + 0.5);
    case PercentileMethod::kR7:
      return interpolate(sorted, (n - 1.0) * p_percent / 100.0 + 1.0);
    case PercentileMethod::kR6:
      return interpolate(sorted, (n + 1.0) * p_percent / 100.0);
    case PercentileMethod::kNearestRank: {
      if (p_percent == 0.0) return sorted.front();
      // n·p first, then /100: exact for integer p, so 95 % of 20 is rank 19, not 20.
      const double rank = std::ceil(n * p_percent / 100.0);
      const auto index = static_cast<std::size_t>(std::clamp(rank, 1.0, n)) - 1;
      return sorted[index];
    }
  }
  return sorted.front();
}

double percentile(std::span<const double> values, double p_percent, PercentileMethod method) {
  std::vector<double> sorted(values.begin(), values.end());
  for (double v : sorted) {
    if (!std::isfinite(v)) throw DataError("percentile(): the sample holds a non-finite value");
  }
  std::sort(sorted.begin(), sorted.end());
  return percentile_sorted(sorted, p_percent, method);
}

}  // namespace hapticlab::analysis
