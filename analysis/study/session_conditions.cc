#include "analysis/study/session_conditions.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <utility>

namespace hapticlab::analysis {
namespace {

constexpr const char* kNotRecorded = "not recorded (sessions before HapticLab schema 10, or the C study API)";

std::string session_list(const std::vector<std::int64_t>& ids) {
  std::string text = ids.size() == 1 ? "session " : "sessions ";
  for (std::size_t k = 0; k < ids.size(); ++k) text += (k > 0 ? ", " : "") + std::to_string(ids[k]);
  return text;
}

// One value: itself; several: "mixed: A (sessions 1, 2); B (session 3)"
// and a warning saying what differs.
std::string describe(const std::map<std::string, std::vector<std::int64_t>>& by_value, const std::string& what,
                     std::vector<std::string>& warnings) {
  if (by_value.empty()) return kNotRecorded;
  if (by_value.size() == 1) return by_value.begin()->first;
  std::string text;
  for (const auto& [value, ids] : by_value) text += (text.empty() ? "" : "; ") + value + " (" + session_list(ids) + ")";
  warnings.push_back("the study's sessions differ in " + what + ": " + text +
                     "; their trials are not comparable (the settings are not the only difference)");
  return "mixed: " + text;
}

// A session's recorded rate against the period its trials' loops measured
// (loop_timing's mean, which is exact; the median over the session's
// trials): the loop's own rate check holds each window within a tolerance
// of the schedule (10 % by default), so a recorded rate further from the
// measured one is not the rate the trials had (an edited file).
constexpr double kRateDisagreementFraction = 0.10;

void check_recorded_rates(db::StudyDb& db, std::int64_t study_id, std::vector<std::string>& warnings) {
  db::Statement s = db.connection().prepare(
      "SELECT s.id, s.rate_Hz, l.mean_period_s FROM session s JOIN participant p ON p.id = s.participant_id "
      "JOIN trial t ON t.session_id = s.id JOIN loop_timing l ON l.trial_id = t.id "
      "WHERE p.study_id = ?1 AND s.rate_Hz IS NOT NULL AND t.status = 'complete' AND l.count > 0 "
      "AND l.mean_period_s > 0 ORDER BY s.id");
  s.bind(1, study_id);
  std::map<std::int64_t, std::pair<double, std::vector<double>>> by_session;
  while (s.step()) {
    auto& [rate, periods] = by_session[s.column_int64(0)];
    rate = s.column_double(1);
    periods.push_back(s.column_double(2));
  }
  for (auto& [id, entry] : by_session) {
    auto& [rate, periods] = entry;
    std::sort(periods.begin(), periods.end());
    const double median_s = periods[periods.size() / 2];
    const double measured_Hz = 1.0 / median_s;
    if (!(std::abs(measured_Hz - rate) > kRateDisagreementFraction * rate)) continue;
    char text[300];
    std::snprintf(text, sizeof text,
                  "session %lld is recorded at %.6g Hz, but its complete trials' loops ran at %.6g Hz (mean "
                  "period %.6g ms, the median over %zu trials): the recorded rate is not the one its trials had",
                  static_cast<long long>(id), rate, measured_Hz, 1e3 * median_s, periods.size());
    warnings.push_back(text);
  }
}

}  // namespace

SessionConditions read_session_conditions(db::StudyDb& db, std::int64_t study_id) {
  db::Statement s = db.connection().prepare(
      "SELECT s.id, s.rate_Hz, s.participant_model FROM session s JOIN participant p ON p.id = s.participant_id "
      "WHERE p.study_id = ?1 AND EXISTS (SELECT 1 FROM trial t WHERE t.session_id = s.id) ORDER BY s.id");
  s.bind(1, study_id);
  std::map<std::string, std::vector<std::int64_t>> rates, participants;
  while (s.step()) {
    const std::int64_t id = s.column_int64(0);
    // A session without a rate was not run by this version's runner: what
    // held the device is not known either.
    if (s.is_null(1)) continue;
    char rate[32];
    std::snprintf(rate, sizeof rate, "%.6g Hz", s.column_double(1));
    rates[rate].push_back(id);
    participants[s.is_null(2) ? std::string("a person at the device") : "simulated, " + s.column_text(2)].push_back(id);
  }
  SessionConditions c;
  c.rate_text = describe(rates, "the haptic loop's rate", c.warnings);
  c.participant_text = describe(participants, "who held the device", c.warnings);
  check_recorded_rates(db, study_id, c.warnings);
  return c;
}

}  // namespace hapticlab::analysis
