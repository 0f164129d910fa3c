#include "analysis/study/staircase_progress.h"

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/stats/percentile.h"
#include "analysis/study/trial_reader.h"
#include "core/common/csv_format.h"
#include "protocols/protocol.h"
#include "protocols/protocol_json.h"

namespace hapticlab::analysis {

double staircase_measure(db::StudyDb& db, const db::TrialRow& trial, const std::string& measure) {
  return staircase_value(read_trial(db, trial, AnalysisOptions{}), measure);
}

std::optional<double> staircase_baseline(const std::vector<double>& values) {
  if (values.empty()) return std::nullopt;
  const double median = percentile(values, 50.0);
  if (!(median > 0.0)) return std::nullopt;
  return median;
}

double staircase_value(const TrialRecord& record, const std::string& measure) {
  for (Measure m : kAllMeasures) {
    if (measure != measure_column(m)) continue;
    std::vector<double> values;
    for (int h = 0; h < (measure_per_hand(m) ? 2 : 1); ++h)
      if (const double v = record.value(m, h); std::isfinite(v)) values.push_back(v);
    return values.empty() ? std::numeric_limits<double>::quiet_NaN() : percentile(values, 50.0);
  }
  throw std::invalid_argument("staircase measure '" + measure + "' is not a measure");
}

std::optional<StaircaseProgress> staircase_progress(db::StudyDb& db, const db::StudyRow& study,
                                                    std::int64_t participant_id) {
  const std::optional<protocols::StaircaseSpec> spec =
      protocols::staircase_from_protocol_text(study.protocol_json, db.path() + ": the study's protocol");
  if (!spec) return std::nullopt;
  StaircaseProgress p;
  p.spec = *spec;
  for (const auto& [id, name] : db.settings(study.id))
    if (name.starts_with(protocols::kStaircaseBasePrefix)) {
      p.base_setting_id = id;
      p.base_name = name.substr(protocols::kStaircaseBasePrefix.size());
    }
  if (p.base_setting_id == 0)
    throw std::runtime_error(db.path() + ": the study has a staircase but no stored staircase settings");

  std::vector<db::TrialRow> mine;
  for (db::TrialRow& t : db.trials(study.id))
    if (t.participant_id == participant_id && t.task == p.spec.task) mine.push_back(std::move(t));
  if (mine.empty()) return std::nullopt;
  std::sort(mine.begin(), mine.end(),
            [](const db::TrialRow& a, const db::TrialRow& b) { return std::pair(a.position, a.id) < std::pair(b.position, b.id); });

  std::vector<double> baseline;
  std::vector<std::pair<double, double>> steps;
  std::string code;
  for (const db::TrialRow& t : mine) {
    code = t.participant_code;
    if (t.block == 0) ++p.started;
    if (t.status != db::TrialStatus::kComplete) continue;
    if (t.block != 0) {
      if (t.setting_name == p.spec.baseline)
        if (const double v = staircase_measure(db, t, p.spec.measure); std::isfinite(v)) baseline.push_back(v);
      continue;
    }
    const nlohmann::json parameters = nlohmann::json::parse(db.setting_json(t.setting_id));
    const nlohmann::json* strength = find_settings_field(parameters, p.spec.field);
    const double v = staircase_measure(db, t, p.spec.measure);
    // A trial without the measure (no task window) cannot move the staircase.
    if (strength != nullptr && strength->is_number() && std::isfinite(v)) steps.emplace_back(strength->get<double>(), v);
  }
  p.baseline_trials = baseline.size();
  if (!baseline.empty()) p.baseline = percentile(baseline, 50.0);
  if (!staircase_baseline(baseline))
    throw StaircaseBaselineError(
        "staircase.baseline: participant " + code + " has " +
        (baseline.empty() ? "no complete trial of the baseline '" + p.spec.baseline + "' in " + p.spec.task +
                                " with a " + p.spec.measure
                          : "a baseline " + p.spec.measure + " of " + format_number(p.baseline) +
                                ", but a change is a fraction of it and needs it above 0") +
        ", so the staircase has nothing to measure a change from; run the participant's '" + p.spec.baseline +
        "' trials first");
  p.state = protocols::replay_staircase(p.spec, p.baseline, steps);
  // Trials that never complete (a strength that always hits the time limit)
  // must not keep the staircase going without end.
  if (!p.state.finished && p.started >= 2 * static_cast<std::size_t>(p.spec.max_trials)) {
    p.state.finished = true;
    p.state.stop_reason = std::to_string(p.started) + " trials started but only " + std::to_string(steps.size()) +
                          " complete (2 x max_trials)";
  }
  return p;
}

namespace {
std::string short_number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}
}  // namespace

std::string staircase_summary(const StaircaseProgress& p) {
  const protocols::StaircaseState& s = p.state;
  std::string out = "staircase of " + p.spec.field + " (" + p.spec.measure + ", " +
                    std::string(protocols::change_direction_name(p.spec.direction)) + " by " +
                    format_number(100.0 * p.spec.change) + " % from the baseline " + short_number(p.baseline) +
                    "): ";
  const std::string counts = std::to_string(s.trials.size()) + " trial" + (s.trials.size() == 1 ? "" : "s") + ", " +
                             std::to_string(s.reversal_strengths.size()) + " reversal" +
                             (s.reversal_strengths.size() == 1 ? "" : "s");
  if (!s.finished) return out + "running, " + counts + ", next strength " + format_number(s.next_strength);
  out += s.threshold ? "threshold " + short_number(*s.threshold) : std::string("no threshold");
  return out + " after " + counts + " (stopped: " + s.stop_reason + ")";
}

}  // namespace hapticlab::analysis
