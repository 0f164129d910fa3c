#include "planning/comparison_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <tuple>

#include "analysis/study/study_analysis.h"
#include "core/common/csv_format.h"

namespace hapticlab::planning {
namespace {

const ChangeRow* find_change(const ReportVariant& v, int n, const std::string& task, const std::string& setting,
                             const std::string& measure) {
  const auto it = std::find_if(v.changes.begin(), v.changes.end(), [&](const ChangeRow& r) {
    return r.participants == n && r.task == task && r.setting == setting && r.measure == measure;
  });
  return it == v.changes.end() ? nullptr : &*it;
}

const PowerRow* find_power(const ReportVariant& v, int n, const std::string& method, const std::string& task,
                           const std::string& setting, const std::string& measure) {
  const auto it = std::find_if(v.power.begin(), v.power.end(), [&](const PowerRow& r) {
    return r.participants == n && r.method == method && r.task == task && r.setting == setting &&
           r.measure == measure;
  });
  return it == v.power.end() ? nullptr : &*it;
}

const TimeoutRow* find_timeouts(const ReportVariant& v, int n, const std::string& task, const std::string& setting) {
  const auto it = std::find_if(v.timeouts.begin(), v.timeouts.end(), [&](const TimeoutRow& r) {
    return r.participants == n && r.task == task && r.setting == setting;
  });
  return it == v.timeouts.end() ? nullptr : &*it;
}

std::string percent(double fraction) {
  char cell[32];
  std::snprintf(cell, sizeof cell, "%+.0f", 100.0 * fraction);
  return std::string(cell) == "-0" ? "+0" : cell;
}

std::string change_cell(const ChangeRow* r) {
  if (r == nullptr) return "—";
  return percent(r->median) + " % [" + percent(r->low) + ", " + percent(r->high) + "]";
}

std::string power_cell(const PowerRow* r) {
  if (r == nullptr) return "—";
  char cell[96];
  int n = std::snprintf(cell, sizeof cell, "%.0f %% [%.0f, %.0f]", 100 * r->rate, 100 * r->wilson_low,
                        100 * r->wilson_high);
  // Studies drawn from a fit's posterior: the interval that adds the
  // model's uncertainty (power.h) beside the sampling-only one.
  if (std::isfinite(r->model_low) && std::isfinite(r->model_high) && n > 0)
    std::snprintf(cell + n, sizeof cell - static_cast<std::size_t>(n), " model [%.0f, %.0f]", 100 * r->model_low,
                  100 * r->model_high);
  return cell;
}

// Every (task, measure, setting) any variant has, tasks in order of first
// appearance, then the measures' order, then the settings'.
std::vector<std::tuple<std::string, std::string, std::string>> lines_of(const std::vector<ReportVariant>& variants,
                                                                        const std::vector<std::string>& settings) {
  std::vector<std::string> tasks;
  std::set<std::tuple<std::string, std::string, std::string>> have;
  auto add = [&](const std::string& task, const std::string& measure, const std::string& setting) {
    if (std::find(tasks.begin(), tasks.end(), task) == tasks.end()) tasks.push_back(task);
    have.insert({task, measure, setting});
  };
  for (const ReportVariant& v : variants) {
    for (const ChangeRow& r : v.changes) add(r.task, r.measure, r.setting);
    for (const PowerRow& r : v.power)
      if (!r.setting.empty()) add(r.task, r.measure, r.setting);
  }
  std::vector<std::string> setting_order = settings;
  for (const auto& [task, measure, setting] : have)
    if (std::find(setting_order.begin(), setting_order.end(), setting) == setting_order.end())
      setting_order.push_back(setting);
  std::vector<std::tuple<std::string, std::string, std::string>> lines;
  for (const std::string& task : tasks)
    for (analysis::Measure m : analysis::kAllMeasures)
      for (const std::string& setting : setting_order)
        if (have.count({task, analysis::measure_column(m), setting}))
          lines.emplace_back(task, analysis::measure_column(m), setting);
  return lines;
}

}  // namespace

std::string comparison_markdown(const std::vector<ReportVariant>& variants, const ComparisonReportOptions& o) {
  const std::string method = o.method == "pairwise" ? "the thesis procedure (pairwise Friedman)"
                                                    : "the participant-level comparison (sign-flip test)";
  std::string md =
      "Each setting against " + o.control +
      ". **These are the model's predictions** — what the simulated surgeons do (docs/simulation.md says where "
      "they match published data and where not) — not measurements. Predicted change: a study's change is the "
      "median over its participants of their median under the setting over their median under " + o.control +
      ", minus 1; the cell is the median simulated study [the 2.5th and 97.5th percentiles of studies]. Power: "
      "the share of simulated studies in which " + method + " finds the setting different from " + o.control +
      " at the Šidák level [Wilson 95 % interval: the simulation's sampling only]; where the studies drew their "
      "populations from a fit's posterior, \"model [ ]\" is the 95 % interval with the model's uncertainty added, "
      "and the predicted change's percentiles include it.";
  for (const ReportVariant& v : variants)
    md += (&v == &variants.front() ? " Variants: " : ", ") + std::string("*") + v.label + "*";
  md += variants.empty() ? "\n" : ".\n";
  const auto lines = lines_of(variants, o.settings);
  // Under a task's table: its settings' trials that timed out.
  auto timeouts = [&](const std::string& of_task) {
    std::string out;
    for (int n : o.participants)
      for (const ReportVariant& v : variants) {
        std::string cells;
        for (const std::string& setting : o.settings)
          if (const TimeoutRow* r = find_timeouts(v, n, of_task, setting)) {
            char cell[160];
            std::snprintf(cell, sizeof cell, "%s %.0f %% [%.0f, %.0f] of %d", setting.c_str(), 100 * r->rate,
                          100 * r->wilson_low, 100 * r->wilson_high, r->trials);
            cells += (cells.empty() ? "" : "; ") + std::string(cell);
          }
        if (cells.empty()) continue;
        out += "\nTrials that timed out, left out of the change and the power (" + std::to_string(n) +
               " participants" + (variants.size() > 1 ? ", " + v.label : std::string()) + "): " + cells + ".\n";
      }
    return out;
  };
  std::string task;
  for (const auto& [line_task, measure, setting] : lines) {
    if (line_task != task) {
      if (!task.empty()) md += timeouts(task);
      task = line_task;
      md += "\n**" + task + "**\n\n| measure | setting |";
      std::string rule = "| --- | --- |";
      for (int n : o.participants)
        for (const ReportVariant& v : variants) {
          const std::string head = std::to_string(n) + " participants" +
                                   (variants.size() > 1 ? ", " + v.label : std::string());
          md += " " + head + ": predicted change | " + head + ": power |";
          rule += " --- | --- |";
        }
      md += "\n" + rule + "\n";
    }
    md += "| " + measure + " | " + setting + " |";
    for (int n : o.participants)
      for (const ReportVariant& v : variants)
        md += ' ' + change_cell(find_change(v, n, task, setting, measure)) + " | " +
              power_cell(find_power(v, n, o.method, task, setting, measure)) + " |";
    md += "\n";
  }
  if (!task.empty()) md += timeouts(task);
  return md;
}

std::string comparison_csv(const std::vector<ReportVariant>& variants, const ComparisonReportOptions& o) {
  std::string csv =
      "variant,participants,task,setting,measure,studies,predicted_change_median,predicted_change_low,"
      "predicted_change_high,participant_power,participant_power_low,participant_power_high,thesis_power,"
      "thesis_power_low,thesis_power_high,trials_run,trials_timed_out,participant_power_model_low,"
      "participant_power_model_high\n";
  auto number = [](double v) { return format_number(v); };
  const auto lines = lines_of(variants, o.settings);  // task, measure, setting
  std::set<int> sizes;
  for (const ReportVariant& v : variants) {
    for (const ChangeRow& r : v.changes) sizes.insert(r.participants);
    for (const PowerRow& r : v.power) sizes.insert(r.participants);
  }
  for (const ReportVariant& v : variants) {
    for (int n : sizes) {
      for (const auto& [task, measure, setting] : lines) {
        const ChangeRow* c = find_change(v, n, task, setting, measure);
        const PowerRow* p = find_power(v, n, "participant_pairwise", task, setting, measure);
        const PowerRow* t = find_power(v, n, "pairwise", task, setting, measure);
        if (!c && !p && !t) continue;
        const TimeoutRow* out = find_timeouts(v, n, task, setting);
        csv += csv_text(v.label) + ',' + std::to_string(n) + ',' + csv_text(task) + ',' + csv_text(setting) + ',' +
               measure + ',' + (c ? std::to_string(c->studies) : "") + ',' + (c ? number(c->median) : "") + ',' +
               (c ? number(c->low) : "") + ',' + (c ? number(c->high) : "") + ',' + (p ? number(p->rate) : "") + ',' +
               (p ? number(p->wilson_low) : "") + ',' + (p ? number(p->wilson_high) : "") + ',' +
               (t ? number(t->rate) : "") + ',' + (t ? number(t->wilson_low) : "") + ',' +
               (t ? number(t->wilson_high) : "") + ',' + (out ? std::to_string(out->trials) : "") + ',' +
               (out ? std::to_string(out->timed_out) : "") + ',' +
               (p && std::isfinite(p->model_low) ? number(p->model_low) : "") + ',' +
               (p && std::isfinite(p->model_high) ? number(p->model_high) : "") + '\n';
      }
    }
  }
  return csv;
}

}  // namespace hapticlab::planning
