#include "analysis/learning/cusum.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis::learning {
namespace {

void require(bool ok, const char* field, double value, const std::string& allowed) {
  if (ok) return;
  std::ostringstream m;
  m << "CUSUM: " << field << " = " << value << " is refused (allowed: " << allowed << ")";
  throw DataError(m.str());
}

}  // namespace

void validate(const CusumSpec& spec) {
  require(spec.p0 > 0.0 && spec.p0 < 1.0, "p0", spec.p0, "0 < p0 < 1");
  require(spec.p1 > 0.0 && spec.p1 < 1.0, "p1", spec.p1, "0 < p1 < 1");
  std::ostringstream above;
  above << "p1 > p0 = " << spec.p0 << ": the unacceptable failure rate must exceed the acceptable one";
  require(spec.p1 > spec.p0, "p1", spec.p1, above.str());
  require(spec.alpha > 0.0 && spec.alpha < 0.5, "alpha", spec.alpha, "0 < alpha < 0.5");
  require(spec.beta > 0.0 && spec.beta < 0.5, "beta", spec.beta, "0 < beta < 0.5");
  if (spec.lc_limit) require(*spec.lc_limit > 0.0 && std::isfinite(*spec.lc_limit), "lc_limit", *spec.lc_limit, "> 0");
}

CusumChart cusum_chart(const std::vector<bool>& failures, const CusumSpec& spec) {
  validate(spec);
  const double p = std::log(spec.p1 / spec.p0);
  const double q = std::log((1.0 - spec.p0) / (1.0 - spec.p1));
  CusumChart chart;
  chart.s = q / (p + q);
  chart.h1 = std::log((1.0 - spec.beta) / spec.alpha) / (p + q);
  chart.h0 = std::log((1.0 - spec.alpha) / spec.beta) / (p + q);
  double score = 0.0, lc = 0.0;
  for (std::size_t t = 0; t < failures.size(); ++t) {
    score += failures[t] ? 1.0 - chart.s : -chart.s;
    lc = std::max(0.0, lc + (failures[t] ? -p : q));
    chart.score.push_back(score);
    chart.lc_score.push_back(lc);
    if (!chart.first_above_h1 && score >= chart.h1) chart.first_above_h1 = t + 1;
    if (!chart.first_below_h0 && score <= -chart.h0) chart.first_below_h0 = t + 1;
    if (spec.lc_limit && !chart.lc_proficient_at && lc >= *spec.lc_limit) chart.lc_proficient_at = t + 1;
  }
  return chart;
}

std::vector<bool> failures_against(const std::vector<double>& values, double criterion,
                                   bool higher_is_better) {
  if (!std::isfinite(criterion)) {
    std::ostringstream m;
    m << "CUSUM: criterion = " << criterion << " is refused (allowed: a finite number)";
    throw DataError(m.str());
  }
  std::vector<bool> out;
  out.reserve(values.size());
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i])) {
      std::ostringstream m;
      m << "CUSUM: trial " << i + 1 << " has value " << values[i] << " (allowed: a finite number)";
      throw DataError(m.str());
    }
    out.push_back(higher_is_better ? values[i] < criterion : values[i] > criterion);
  }
  return out;
}

}  // namespace hapticlab::analysis::learning
