#include "analysis/stats/sign_flip_vs_control.h"

#include <algorithm>

#include "analysis/stats/sign_flip.h"

namespace hapticlab::analysis {

std::vector<SignFlipComparison> sign_flip_vs_control(const BlockTable& table, const std::string& control,
                                                     double level, PercentileMethod median_method) {
  const std::size_t c = table.treatment_index(control);
  auto median = [&](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return percentile_sorted(v, 50.0, median_method);
  };
  std::vector<SignFlipComparison> out;
  for (std::size_t t = 0; t < table.treatment_count(); ++t) {
    if (t == c) continue;
    SignFlipComparison cmp;
    cmp.treatment = table.treatment_names[t];
    std::vector<double> differences;
    for (std::size_t b = 0; b < table.block_count(); ++b) {
      const auto& treated = table.cells[b][t];
      const auto& controlled = table.cells[b][c];
      if (treated.empty() || controlled.empty()) continue;
      differences.push_back(median(treated) - median(controlled));
    }
    cmp.blocks = differences.size();
    if (!differences.empty()) {
      const SignFlipResult r = sign_flip_test(differences);
      cmp.p = r.p;
      cmp.mean_difference = r.mean;
      cmp.significant = r.p < level;
    }
    out.push_back(std::move(cmp));
  }
  return out;
}

}  // namespace hapticlab::analysis
