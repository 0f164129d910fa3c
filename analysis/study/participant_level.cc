#include "analysis/study/participant_level.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "analysis/stats/percentile.h"
#include "analysis/stats/sign_flip.h"

namespace hapticlab::analysis {

std::vector<ParticipantPairwiseCell> participant_pairwise(const StudyAnalysis& a) {
  std::vector<ParticipantPairwiseCell> out;
  if (a.control.empty()) return out;
  for (const std::string& task : a.tasks) {
    for (Measure m : kAllMeasures) {
      // participant -> setting -> values over repetitions (and hands)
      std::map<std::string, std::map<std::string, std::vector<double>>> values;
      for (const TrialRecord& t : a.trials) {
        if (t.task != task) continue;
        for (int h = 0; h < (measure_per_hand(m) ? 2 : 1); ++h) {
          const double v = t.value(m, h);
          if (std::isfinite(v)) values[t.participant][t.setting].push_back(v);
        }
      }
      auto median = [&](std::vector<double> v) {
        std::sort(v.begin(), v.end());
        return percentile_sorted(v, 50.0, a.options.percentile_method);
      };
      for (const std::string& setting : a.settings) {
        if (setting == a.control) continue;
        ParticipantPairwiseCell cell;
        cell.task = task;
        cell.setting = setting;
        cell.measure = m;
        std::vector<double> differences;
        for (const auto& [participant, by_setting] : values) {
          const auto c = by_setting.find(a.control);
          const auto s = by_setting.find(setting);
          if (c == by_setting.end() || s == by_setting.end()) continue;
          differences.push_back(median(s->second) - median(c->second));
        }
        cell.participants = differences.size();
        if (differences.empty()) {
          cell.note = "no participant has data for both settings";
        } else {
          const SignFlipResult r = sign_flip_test(differences);
          cell.p = r.p;
          cell.mean_difference = r.mean;
          cell.significant = r.p < a.sidak_level;
        }
        out.push_back(std::move(cell));
      }
    }
  }
  return out;
}

}  // namespace hapticlab::analysis
