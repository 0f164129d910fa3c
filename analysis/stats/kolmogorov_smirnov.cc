#include "analysis/stats/kolmogorov_smirnov.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "analysis/stats/data_error.h"
#include "analysis/stats/distributions.h"

namespace hapticlab::analysis {

double ks_statistic_sorted(std::span<const double> a, std::span<const double> b) {
  const double n1 = static_cast<double>(a.size());
  const double n2 = static_cast<double>(b.size());
  std::size_t i = 0;
  std::size_t j = 0;
  double d = 0.0;
  // Walk both sorted samples; at each distinct value advance past every copy
  // in both samples, then compare the two step functions.
  while (i < a.size() && j < b.size()) {
    const double x = std::min(a[i], b[j]);
    while (i < a.size() && a[i] == x) ++i;
    while (j < b.size() && b[j] == x) ++j;
    d = std::max(d, std::fabs(static_cast<double>(i) / n1 - static_cast<double>(j) / n2));
  }
  return d;
}

double ks_statistic(std::span<const double> a, std::span<const double> b) {
  std::vector<double> sa(a.begin(), a.end());
  std::vector<double> sb(b.begin(), b.end());
  std::sort(sa.begin(), sa.end());
  std::sort(sb.begin(), sb.end());
  return ks_statistic_sorted(sa, sb);
}

KsResult ks_test(std::span<const double> a, std::span<const double> b) {
  if (a.empty() || b.empty()) {
    throw DataError("ks_test(): both samples need at least one value (sizes " +
                    std::to_string(a.size()) + " and " + std::to_string(b.size()) + ")");
  }
  for (auto sample : {a, b}) {
    for (double v : sample) {
      if (!std::isfinite(v)) throw DataError("ks_test(): a sample holds a non-finite value");
    }
  }
  KsResult result;
  result.n1 = a.size();
  result.n2 = b.size();
  result.d = ks_statistic(a, b);
  const double n1 = static_cast<double>(a.size());
  const double n2 = static_cast<double>(b.size());
  result.p = kolmogorov_upper(std::sqrt(n1 * n2 / (n1 + n2)) * result.d);
  return result;
}

}  // namespace hapticlab::analysis
