#include "analysis/transfer/hodges_lehmann.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis::transfer {
namespace {

// Distribution of U as probabilities: walk the m + n ordered positions,
// each taken by an x (adding the number of y's already placed to U) or a y.
std::vector<double> mann_whitney_pmf(std::size_t m, std::size_t n) {
  const std::size_t max_u = m * n;
  // dp[j][u]: ways with j y's placed so far; positions so far = i.
  std::vector<std::vector<double>> dp(n + 1, std::vector<double>(max_u + 1, 0.0));
  dp[0][0] = 1.0;
  for (std::size_t i = 0; i < m + n; ++i) {
    std::vector<std::vector<double>> next(n + 1, std::vector<double>(max_u + 1, 0.0));
    for (std::size_t j = 0; j <= std::min(i, n); ++j) {
      const std::size_t xs = i - j;
      for (std::size_t u = 0; u <= max_u; ++u) {
        const double w = dp[j][u];
        if (w == 0.0) continue;
        if (xs < m && u + j <= max_u) next[j][u + j] += w;
        if (j < n) next[j + 1][u] += w;
      }
    }
    dp.swap(next);
  }
  std::vector<double> pmf = dp[n];
  double total = 0.0;
  for (double w : pmf) total += w;
  for (double& w : pmf) w /= total;
  return pmf;
}

void check(const std::vector<double>& v, const char* name) {
  if (v.empty()) throw DataError(std::string("Hodges-Lehmann shift: group ") + name + " has no values (allowed: at least 1)");
  for (double x : v) {
    if (!std::isfinite(x)) {
      std::ostringstream m;
      m << "Hodges-Lehmann shift: group " << name << " has value " << x << " (allowed: finite)";
      throw DataError(m.str());
    }
  }
}

}  // namespace

double mann_whitney_cdf(std::size_t u, std::size_t m, std::size_t n) {
  const auto pmf = mann_whitney_pmf(m, n);
  double p = 0.0;
  for (std::size_t k = 0; k <= std::min(u, pmf.size() - 1); ++k) p += pmf[k];
  return std::min(p, 1.0);
}

ShiftEstimate hodges_lehmann_shift(const std::vector<double>& x, const std::vector<double>& y,
                                   double level) {
  check(x, "x");
  check(y, "y");
  if (!(level > 0.0 && level < 1.0)) {
    std::ostringstream m;
    m << "Hodges-Lehmann shift: level = " << level << " (allowed: 0 < level < 1)";
    throw DataError(m.str());
  }
  if (x.size() * y.size() > 1000000) {
    std::ostringstream m;
    m << "Hodges-Lehmann shift: " << x.size() << " x " << y.size()
      << " pairwise differences (allowed: at most 10^6)";
    throw DataError(m.str());
  }
  std::vector<double> d;
  d.reserve(x.size() * y.size());
  for (double xi : x)
    for (double yj : y) d.push_back(yj - xi);
  std::sort(d.begin(), d.end());
  const std::size_t big_n = d.size();
  ShiftEstimate est;
  est.shift = big_n % 2 == 1 ? d[big_n / 2] : 0.5 * (d[big_n / 2 - 1] + d[big_n / 2]);
  const auto pmf = mann_whitney_pmf(x.size(), y.size());
  const double tail = (1.0 - level) / 2.0;
  // k = largest integer with P(U <= k - 1) <= tail.
  std::size_t k = 0;
  double cdf_below = 0.0;  // P(U <= k - 1) for the next k
  while (k < pmf.size() && cdf_below + pmf[k] <= tail * (1.0 + 1e-12)) {
    cdf_below += pmf[k];
    ++k;
  }
  if (k == 0) {
    std::ostringstream m;
    m << "groups of " << x.size() << " and " << y.size() << " cannot give a " << level * 100
      << " % interval (the smallest two-sided tail is " << 2.0 * pmf[0] << ")";
    est.no_interval_reason = m.str();
    return est;
  }
  est.has_interval = true;
  est.low = d[k - 1];
  est.high = d[big_n - k];
  est.achieved_level = 1.0 - 2.0 * cdf_below;
  return est;
}

}  // namespace hapticlab::analysis::transfer
