#include "analysis/study/dose_response.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <nlohmann/json.hpp>

#include "analysis/stats/data_error.h"
#include "analysis/stats/percentile.h"
#include "analysis/stats/sign_flip.h"
#include "core/common/csv_format.h"
#include "core/settings/settings_json.h"

namespace hapticlab::analysis {
namespace {

using nlohmann::json;

constexpr double kNoDoseValue = std::numeric_limits<double>::quiet_NaN();

// The field's value in a stored setting, and whether its effect is on (a
// field of a block without "enabled" always acts).
std::pair<double, bool> field_in(const std::string& setting, const std::string& parameters_json,
                                 const std::string& field) {
  const json j = json::parse(parameters_json, nullptr, false);
  const json* leaf = j.is_discarded() ? nullptr : find_settings_field(j, field);
  if (leaf == nullptr || !leaf->is_number())
    throw DataError("the dose field " + field + " is not a number in the stored parameters of setting '" + setting +
                    "'");
  const std::string dotted_block = field.substr(0, field.rfind('.'));
  const json* enabled = find_settings_field(j, dotted_block + ".enabled");
  return {leaf->get<double>(), enabled == nullptr || !enabled->is_boolean() || enabled->get<bool>()};
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() > suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// Least-squares slope of y on x; empty with fewer than two distinct x.
std::optional<double> slope(const std::vector<double>& x, const std::vector<double>& y) {
  double mx = 0.0, my = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) mx += x[i], my += y[i];
  mx /= static_cast<double>(x.size());
  my /= static_cast<double>(x.size());
  double sxy = 0.0, sxx = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sxy += (x[i] - mx) * (y[i] - my);
    sxx += (x[i] - mx) * (x[i] - mx);
  }
  if (x.size() < 2 || !(sxx > 0.0)) return std::nullopt;
  return sxy / sxx;
}

}  // namespace

std::optional<DoseSeries> find_dose_series(std::string_view protocol_json, const std::string& control,
                                           const std::vector<std::pair<std::string, std::string>>& settings_json) {
  const json protocol = json::parse(protocol_json, nullptr, false);
  if (protocol.is_discarded() || !protocol.is_object() || !protocol.contains("dose")) return std::nullopt;
  // The protocol was validated when the study was created; a stored text
  // that no longer reads as it did is named rather than guessed at.
  const json& dose = protocol["dose"];
  if (!dose.is_object() || !dose.contains("field") || !dose["field"].is_string() || !dose.contains("strengths") ||
      !dose["strengths"].is_array())
    throw DataError("the study's stored protocol has a \"dose\" block without a field and a list of strengths");
  DoseSeries series;
  series.field = dose["field"].get<std::string>();
  const auto control_it = std::find_if(settings_json.begin(), settings_json.end(),
                                       [&](const auto& s) { return s.first == control; });
  if (control_it == settings_json.end()) return std::nullopt;
  const auto [control_value, control_on] = field_in(control, control_it->second, series.field);
  series.levels.push_back({control, control_on ? control_value : 0.0});
  for (const json& item : dose["strengths"]) {
    if (!item.is_number()) throw DataError("the study's stored protocol has a dose strength that is not a number");
    const double strength = item.get<double>();
    const std::string suffix = dose_setting_name("", series.field, strength);
    for (const auto& [name, parameters] : settings_json) {
      if (name == control || !ends_with(name, suffix)) continue;
      const auto [value, on] = field_in(name, parameters, series.field);
      if (!on || value != strength)
        throw DataError("setting '" + name + "' is named as the dose strength " + format_number(strength) + ", but its " +
                        series.field + " is " + format_number(value) + (on ? "" : " with its effect off"));
      series.levels.push_back({name, strength});
      break;
    }
  }
  if (series.levels.size() < 2) return std::nullopt;
  return series;
}

std::vector<DoseResponseRow> dose_response(const StudyAnalysis& a) {
  std::vector<DoseResponseRow> rows;
  if (!a.dose || a.dose->levels.size() < 2) return rows;
  const std::vector<DoseLevel>& levels = a.dose->levels;
  for (const std::string& task : a.tasks) {
    for (Measure m : kAllMeasures) {
      DoseResponseRow row;
      row.task = task;
      row.measure = m;
      std::vector<double> slopes;
      std::vector<std::vector<double>> per_level(levels.size());
      for (const std::string& participant : a.participants) {
        DoseParticipantFit fit;
        fit.participant = participant;
        std::vector<double> x, y;
        for (const DoseLevel& level : levels) {
          std::vector<double> values;
          for (const TrialRecord& t : a.trials) {
            if (t.task != task || t.participant != participant || t.setting != level.setting) continue;
            for (int h = 0; h < (measure_per_hand(m) ? 2 : 1); ++h)
              if (const double v = t.value(m, h); std::isfinite(v)) values.push_back(v);
          }
          const double median = values.empty() ? kNoDoseValue : percentile(values, 50.0, a.options.percentile_method);
          fit.medians.push_back(median);
          if (std::isfinite(median)) {
            x.push_back(level.strength);
            y.push_back(median);
            per_level[fit.medians.size() - 1].push_back(median);
          }
        }
        if (x.empty()) continue;  // did not do this task
        fit.slope = slope(x, y);
        if (fit.slope) slopes.push_back(*fit.slope);
        row.participants.push_back(std::move(fit));
      }
      for (const auto& medians : per_level)
        row.level_medians.push_back(medians.empty() ? kNoDoseValue : percentile(medians, 50.0, a.options.percentile_method));
      row.slopes = slopes.size();
      if (!slopes.empty()) {
        const SignFlipResult trend = sign_flip_test(slopes, a.options.seed);
        row.trend_p = trend.p;
        row.mean_slope = trend.mean;
        row.trend_significant = trend.p < a.options.alpha;
      } else {
        row.note = "no participant has data at two strengths";
      }
      // Each strength against the control, then the fixed sequence from the top.
      row.p_vs_control.assign(levels.size(), std::nullopt);
      for (std::size_t i = 1; i < levels.size(); ++i)
        for (const ParticipantPairwiseCell& c : a.participant_pairwise)
          if (c.task == task && c.measure == m && c.setting == levels[i].setting) row.p_vs_control[i] = c.p;
      for (std::size_t i = levels.size() - 1; i >= 1; --i) {
        if (!row.p_vs_control[i] || !(*row.p_vs_control[i] < a.options.alpha)) break;
        row.smallest_significant_strength = levels[i].strength;
      }
      rows.push_back(std::move(row));
    }
  }
  return rows;
}

}  // namespace hapticlab::analysis
