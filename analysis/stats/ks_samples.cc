// Gathers the pooled samples and per-participant series of a KS comparison (ks_samples.h).
#include "analysis/stats/ks_samples.h"

#include <map>
#include <tuple>
#include <utility>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {

KsSamples gather_ks_samples(const std::vector<Observation>& observations, const std::vector<std::size_t>& rows,
                            const std::string& control, const std::string& other, const std::string& source,
                            const std::string& treatment_column) {
  KsSamples s;
  // participant -> repetition -> series, in file order
  std::map<std::string, std::size_t> participant_index;
  std::map<std::tuple<std::string, std::string, std::string>, std::size_t> series_index;
  bool seen_control = false;
  bool seen_other = false;
  for (std::size_t r : rows) {
    const auto& o = observations[r];
    const bool is_control = o.treatment == control;
    const bool is_other = o.treatment == other;
    seen_control |= is_control;
    seen_other |= is_other;
    if (!is_control && !is_other) continue;
    (is_control ? s.control : s.other).push_back(o.value);
    auto [pit, new_participant] = participant_index.emplace(o.block, s.participants.size());
    if (new_participant) s.participants.push_back({o.block, {}, {}});
    auto& reps = is_control ? s.participants[pit->second].control : s.participants[pit->second].other;
    auto [sit, new_series] = series_index.emplace(std::tuple{o.block, o.treatment, o.replicate}, reps.size());
    if (new_series) reps.emplace_back();
    reps[sit->second].push_back(o.value);
  }
  for (const auto& [name, seen] : {std::pair{&control, seen_control}, std::pair{&other, seen_other}}) {
    if (!seen) throw DataError(source + ": no rows with " + treatment_column + " = '" + *name + "'");
  }
  return s;
}

}  // namespace hapticlab::analysis
