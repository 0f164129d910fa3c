#include "planning/study_change.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "analysis/stats/percentile.h"

namespace hapticlab::planning {

std::vector<ChangeOutcome> changes_of(const analysis::StudyAnalysis& a) {
  std::vector<ChangeOutcome> out;
  if (a.control.empty()) return out;
  const auto median = [&](std::vector<double>& v) {
    std::sort(v.begin(), v.end());
    return analysis::percentile_sorted(v, 50.0, a.options.percentile_method);
  };
  for (const std::string& task : a.tasks) {
    for (analysis::Measure m : analysis::kAllMeasures) {
      // setting -> participant -> the values of their cell (repetitions x hands)
      std::map<std::string, std::map<std::string, std::vector<double>>> cells;
      for (const analysis::TrialRecord& t : a.trials) {
        if (t.task != task) continue;
        for (int h = 0; h < (analysis::measure_per_hand(m) ? 2 : 1); ++h) {
          const double v = t.value(m, h);
          if (std::isfinite(v)) cells[t.setting][t.participant].push_back(v);
        }
      }
      auto control = cells.find(a.control);
      if (control == cells.end()) continue;
      for (const std::string& setting : a.settings) {
        if (setting == a.control || !cells.count(setting)) continue;
        std::vector<double> ratios;
        for (auto& [participant, values] : cells[setting]) {
          auto base = control->second.find(participant);
          if (base == control->second.end()) continue;
          const double denominator = median(base->second);
          if (denominator > 0.0) ratios.push_back(median(values) / denominator);
        }
        if (ratios.empty()) continue;
        out.push_back({task, setting, analysis::measure_column(m), static_cast<int>(ratios.size()), median(ratios)});
      }
    }
  }
  return out;
}

}  // namespace hapticlab::planning
