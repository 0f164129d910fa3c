#include "analysis/stats/percentile.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "analysis/stats/data_error.h"
#include "analysis/stats/order_statistics.h"

namespace hapticlab::analysis {
namespace {

// Linear interpolation at 1-based fractional position h, clamped to [1, n],
// as a position: the value is x[lower] + fraction·(x[upper] − x[lower]).
PercentilePosition interpolation_position(std::size_t n, double h) {
  const double nd = static_cast<double>(n);
  if (h <= 1.0) return {0, 0, 0.0};
  if (h >= nd) return {n - 1, n - 1, 0.0};
  const double lower = std::floor(h);
  const auto i = static_cast<std::size_t>(lower) - 1;  // 0-based index of the lower neighbour
  return {i, i + 1, h - lower};
}

double value_at(const PercentilePosition& pos, double lower_value, double upper_value) {
  if (pos.upper == pos.lower) return lower_value;
  return lower_value + pos.fraction * (upper_value - lower_value);
}

void check_p(double p_percent) {
  if (!(p_percent >= 0.0 && p_percent <= 100.0)) {
    throw DataError("percentile: p is " + std::to_string(p_percent) +
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

PercentilePosition percentile_position(std::size_t n, double p_percent, PercentileMethod method) {
  check_p(p_percent);
  if (n == 0) throw DataError("percentile: the sample is empty");
  const double nd = static_cast<double>(n);
  switch (method) {
    case PercentileMethod::kMatlab:
      // x(i) at 100(i - 0.5)/n  <=>  i = n p/100 + 0.5
      return interpolation_position(n, nd * p_percent / 100.0 + 0.5);
    case PercentileMethod::kR7:
      return interpolation_position(n, (nd - 1.0) * p_percent / 100.0 + 1.0);
    case PercentileMethod::kR6:
      return interpolation_position(n, (nd + 1.0) * p_percent / 100.0);
    case PercentileMethod::kNearestRank: {
      if (p_percent == 0.0) return {0, 0, 0.0};
      // n·p first, then /100: exact for integer p, so 95 % of 20 is rank 19, not 20.
      const double rank = std::ceil(nd * p_percent / 100.0);
      const auto index = static_cast<std::size_t>(std::clamp(rank, 1.0, nd)) - 1;
      return {index, index, 0.0};
    }
  }
  return {0, 0, 0.0};
}

double percentile_sorted(std::span<const double> sorted, double p_percent, PercentileMethod method) {
  const PercentilePosition pos = percentile_position(sorted.size(), p_percent, method);
  return value_at(pos, sorted[pos.lower], sorted[pos.upper]);
}

std::vector<double> percentiles_select(std::vector<double>& values, std::span<const double> p_percents,
                                       PercentileMethod method) {
  std::vector<PercentilePosition> positions;
  positions.reserve(p_percents.size());
  std::vector<std::size_t> ranks;
  for (double p : p_percents) {
    positions.push_back(percentile_position(values.size(), p, method));
    ranks.push_back(positions.back().lower);
    ranks.push_back(positions.back().upper);
  }
  std::sort(ranks.begin(), ranks.end());
  ranks.erase(std::unique(ranks.begin(), ranks.end()), ranks.end());
  const std::vector<double> at_rank = order_statistics(values, ranks);
  const auto value_of = [&](std::size_t rank) {
    return at_rank[static_cast<std::size_t>(std::lower_bound(ranks.begin(), ranks.end(), rank) - ranks.begin())];
  };
  std::vector<double> out;
  out.reserve(positions.size());
  for (const auto& pos : positions) out.push_back(value_at(pos, value_of(pos.lower), value_of(pos.upper)));
  return out;
}

double percentile(std::span<const double> values, double p_percent, PercentileMethod method) {
  std::vector<double> sorted(values.begin(), values.end());
  for (double v : sorted) {
    if (!std::isfinite(v)) throw DataError("percentile: the sample holds a non-finite value");
  }
  std::sort(sorted.begin(), sorted.end());
  return percentile_sorted(sorted, p_percent, method);
}

}  // namespace hapticlab::analysis
