#include "planning/change_summary.h"

#include <algorithm>
#include <map>
#include <tuple>

#include "analysis/stats/percentile.h"
#include "analysis/stats/wilson.h"

namespace hapticlab::planning {

std::vector<ChangeRow> summarize_changes(const std::vector<StudyOutcome>& outcomes,
                                         const std::vector<std::string>& setting_order) {
  auto rank = [&](const std::string& setting) {
    return static_cast<std::size_t>(std::find(setting_order.begin(), setting_order.end(), setting) -
                                    setting_order.begin());
  };
  using Key = std::tuple<int, std::string, std::size_t, std::string, std::string>;
  std::map<Key, std::vector<double>> changes;
  for (const StudyOutcome& o : outcomes)
    for (const ChangeOutcome& c : o.changes)
      changes[{o.participants, c.task, rank(c.setting), c.setting, c.measure}].push_back(c.ratio - 1.0);
  std::vector<ChangeRow> rows;
  for (auto& [key, values] : changes) {
    std::sort(values.begin(), values.end());
    ChangeRow r;
    std::size_t ignored_rank = 0;
    std::tie(r.participants, r.task, ignored_rank, r.setting, r.measure) = key;
    r.studies = static_cast<int>(values.size());
    r.median = analysis::percentile_sorted(values, 50.0);
    r.low = analysis::percentile_sorted(values, 2.5);
    r.high = analysis::percentile_sorted(values, 97.5);
    rows.push_back(std::move(r));
  }
  return rows;
}

std::vector<TimeoutRow> summarize_timeouts(const std::vector<StudyOutcome>& outcomes,
                                           const std::vector<std::string>& setting_order) {
  auto rank = [&](const std::string& setting) {
    return static_cast<std::size_t>(std::find(setting_order.begin(), setting_order.end(), setting) -
                                    setting_order.begin());
  };
  std::map<std::tuple<int, std::string, std::size_t, std::string>, TimeoutRow> tally;
  for (const StudyOutcome& o : outcomes)
    for (const SettingTrials& t : o.setting_trials) {
      TimeoutRow& r = tally[{o.participants, t.task, rank(t.setting), t.setting}];
      r.participants = o.participants;
      r.task = t.task;
      r.setting = t.setting;
      r.trials += t.run;
      r.timed_out += t.timed_out;
    }
  std::vector<TimeoutRow> rows;
  for (auto& [key, r] : tally) {
    if (r.trials == 0) continue;
    r.rate = static_cast<double>(r.timed_out) / r.trials;
    const analysis::ProportionInterval ci =
        analysis::wilson_interval(static_cast<std::size_t>(r.timed_out), static_cast<std::size_t>(r.trials));
    r.wilson_low = ci.low;
    r.wilson_high = ci.high;
    rows.push_back(r);
  }
  return rows;
}

}  // namespace hapticlab::planning
