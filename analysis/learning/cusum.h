#pragma once
// CUSUM learning curve against a proficiency criterion (issue 38 §2;
// docs/analysis.md "CUSUM learning curve"). Each trial is a success or a
// failure against the criterion; the chart is the sequential probability
// ratio test of an acceptable failure rate p0 against an unacceptable p1
// with error rates alpha and beta (Wald 1945; as charted by Williams,
// Parry & Schlup 1992 and Bolsin & Colson 2000):
//
//   P = ln(p1/p0), Q = ln((1-p0)/(1-p1)), s = Q / (P + Q)
//   h1 = ln((1-beta)/alpha) / (P + Q)   (upper limit: failure rate is p1)
//   h0 = ln((1-alpha)/beta) / (P + Q)   (lower limit -h0: rate is p0)
//   score_t = score_{t-1} + (1 - s) on a failure, - s on a success
//
// and, for when a learner becomes proficient, the LC-CUSUM (Biau et al.
// 2008) score: lc_t = max(0, lc_{t-1} + Q) on a success, + ln(p0/p1) on a
// failure, signalling at a declared limit h_lc.
#include <cstddef>
#include <optional>
#include <vector>

namespace hapticlab::analysis::learning {

struct CusumSpec {
  double p0 = 0.1;     // acceptable failure rate, in (0, 1)
  double p1 = 0.2;     // unacceptable failure rate, in (p0, 1)
  double alpha = 0.1;  // probability of crossing h1 when the rate is p0, in (0, 0.5)
  double beta = 0.1;   // probability of crossing -h0 when the rate is p1, in (0, 0.5)
  std::optional<double> lc_limit;  // LC-CUSUM decision limit h_lc (log-likelihood units), > 0
};

// Throws DataError naming the field, its value and the allowed range
// (p1 <= p0 included).
void validate(const CusumSpec& spec);

struct CusumChart {
  double s = 0.0, h0 = 0.0, h1 = 0.0;
  std::vector<double> score;     // after each trial, starting from 0
  std::vector<double> lc_score;  // LC-CUSUM after each trial
  // 1-based trial of the first crossing of each limit, if any.
  std::optional<std::size_t> first_above_h1;     // unacceptable (rate p1)
  std::optional<std::size_t> first_below_h0;     // acceptable (rate p0)
  std::optional<std::size_t> lc_proficient_at;   // lc_score >= lc_limit
};

CusumChart cusum_chart(const std::vector<bool>& failures, const CusumSpec& spec);

// Failures from a measure and a criterion: a trial fails when its value is
// above the criterion (lower is better, e.g. completion_time_s) or below it
// when `higher_is_better`. Throws DataError for a non-finite value or
// criterion.
std::vector<bool> failures_against(const std::vector<double>& values, double criterion,
                                   bool higher_is_better);

}  // namespace hapticlab::analysis::learning
