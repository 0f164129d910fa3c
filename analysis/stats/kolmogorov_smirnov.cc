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

double ks_exact_p(std::span<const double> a, std::span<const double> b) {
  std::vector<double> sa(a.begin(), a.end());
  std::vector<double> sb(b.begin(), b.end());
  std::sort(sa.begin(), sa.end());
  std::sort(sb.begin(), sb.end());
  std::vector<double> pooled(sa);
  pooled.insert(pooled.end(), sb.begin(), sb.end());
  std::sort(pooled.begin(), pooled.end());
  const std::size_t n1 = sa.size();
  const std::size_t n2 = sb.size();
  const std::size_t n = n1 + n2;
  // The path may be judged after its k-th step only where pooled[k-1] <
  // pooled[k]: inside a run of ties both ECDFs have not finished stepping.
  const auto judged = [&](std::size_t k) { return k == n || pooled[k - 1] < pooled[k]; };
  // Gaps in units of 1/(n1·n2): |i·n2 − j·n1|, exact in integers.
  const auto gap = [&](std::size_t i, std::size_t j) {
    const auto x = static_cast<long long>(i * n2);
    const auto y = static_cast<long long>(j * n1);
    return x > y ? x - y : y - x;
  };
  long long observed = 0;
  {
    std::size_t i = 0;
    std::size_t j = 0;
    while (i < n1 && j < n2) {
      const double x = std::min(sa[i], sb[j]);
      while (i < n1 && sa[i] == x) ++i;
      while (j < n2 && sb[j] == x) ++j;
      observed = std::max(observed, gap(i, j));
    }
  }
  if (observed == 0) return 1.0;

  // hit[j] after row i: the share of paths to (i, j) that have already reached
  // the observed gap, each path weighted by its probability, so the sum is
  // built from non-negative terms only and a tiny p keeps its precision
  // (1 − P(D < d) would cancel). all[j]: probability of reaching (i, j) at all,
  // C(i+j, i)·C(n−i−j, n1−i)/C(n, n1), carried as the step weights
  // (n1 − i)/(n − i − j) and (n2 − j)/(n − i − j).
  std::vector<double> all(n2 + 1, 0.0);
  std::vector<double> hit(n2 + 1, 0.0);
  for (std::size_t i = 0; i <= n1; ++i) {
    for (std::size_t j = 0; j <= n2; ++j) {
      double p_all = 0.0;
      double p_hit = 0.0;
      if (i == 0 && j == 0) {
        p_all = 1.0;
      } else {
        const std::size_t k = i + j;
        const double remaining = static_cast<double>(n - (k - 1));
        if (i > 0) {  // from (i−1, j) with a value of sample a
          const double w = static_cast<double>(n1 - (i - 1)) / remaining;
          p_all += all[j] * w;
          p_hit += hit[j] * w;
        }
        if (j > 0) {  // from (i, j−1) with a value of sample b
          const double w = static_cast<double>(n2 - (j - 1)) / remaining;
          p_all += all[j - 1] * w;
          p_hit += hit[j - 1] * w;
        }
        if (judged(k) && gap(i, j) >= observed) p_hit = p_all;
      }
      all[j] = p_all;
      hit[j] = p_hit;
    }
  }
  return std::min(1.0, hit[n2]);
}

KsResult ks_test(std::span<const double> a, std::span<const double> b) {
  if (a.empty() || b.empty()) {
    throw DataError("Kolmogorov-Smirnov test: both samples need at least one value (sizes " +
                    std::to_string(a.size()) + " and " + std::to_string(b.size()) + ")");
  }
  for (auto sample : {a, b}) {
    for (double v : sample) {
      if (!std::isfinite(v)) throw DataError("Kolmogorov-Smirnov test: a sample holds a non-finite value");
    }
  }
  KsResult result;
  result.n1 = a.size();
  result.n2 = b.size();
  result.d = ks_statistic(a, b);
  const double n1 = static_cast<double>(a.size());
  const double n2 = static_cast<double>(b.size());
  result.p_asymptotic = kolmogorov_upper(std::sqrt(n1 * n2 / (n1 + n2)) * result.d);
  result.exact = a.size() * b.size() < kKsExactLimit;
  result.p = result.exact ? ks_exact_p(a, b) : result.p_asymptotic;
  return result;
}

}  // namespace hapticlab::analysis
