#include "analysis/study/participant_level.h"

#include <algorithm>
#include <cmath>

#include "analysis/stats/block_table.h"
#include "analysis/stats/sign_flip_vs_control.h"

namespace hapticlab::analysis {

std::vector<ParticipantPairwiseCell> participant_pairwise(const StudyAnalysis& a) {
  std::vector<ParticipantPairwiseCell> out;
  if (a.control.empty()) return out;
  for (const std::string& task : a.tasks) {
    for (Measure m : kAllMeasures) {
      // Blocks are participants; a participant's repetitions (and both hands,
      // for a per-hand measure) are the values of one cell.
      std::vector<Observation> observations;
      for (const TrialRecord& t : a.trials) {
        if (t.task != task) continue;
        for (int h = 0; h < (measure_per_hand(m) ? 2 : 1); ++h) {
          const double v = t.value(m, h);
          if (std::isfinite(v)) observations.push_back({t.participant, t.setting, "", v});
        }
      }
      const BlockTable table = BlockTable::from_observations(observations);
      const bool has_control = std::find(table.treatment_names.begin(), table.treatment_names.end(), a.control) !=
                               table.treatment_names.end();
      std::vector<SignFlipComparison> comparisons;
      if (has_control)
        comparisons = sign_flip_vs_control(table, a.control, a.sidak_level, a.options.percentile_method);
      for (const std::string& setting : a.settings) {
        if (setting == a.control) continue;
        ParticipantPairwiseCell cell;
        cell.task = task;
        cell.setting = setting;
        cell.measure = m;
        const auto found = std::find_if(comparisons.begin(), comparisons.end(),
                                        [&](const SignFlipComparison& c) { return c.treatment == setting; });
        if (found != comparisons.end() && found->p) {
          cell.participants = found->blocks;
          cell.p = found->p;
          cell.mean_difference = found->mean_difference;
          cell.significant = found->significant;
        } else {
          cell.note = "no participant has data for both settings";
        }
        out.push_back(std::move(cell));
      }
    }
  }
  return out;
}

}  // namespace hapticlab::analysis
