#include "planning/power.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <tuple>

#include "analysis/stats/wilson.h"
#include "core/common/random.h"
#include "protocols/rng.h"

namespace hapticlab::planning {

namespace {

// The rows of a tally, each with its rate and 95 % Wilson interval.
template <typename Map, typename Row>
std::vector<Row> with_rates(Map& rows, int Row::*hits, int Row::*total) {
  std::vector<Row> out;
  for (auto& [key, r] : rows) {
    r.rate = static_cast<double>(r.*hits) / r.*total;
    const analysis::ProportionInterval ci = analysis::wilson_interval(r.*hits, r.*total);
    r.wilson_low = ci.low;
    r.wilson_high = ci.high;
    out.push_back(r);
  }
  return out;
}

}  // namespace

std::uint64_t study_seed(std::uint64_t seed, int participants, int index) {
  return Random::derive(seed, protocols::fnv1a64("plan power/participants=" + std::to_string(participants) +
                                                 "/study=" + std::to_string(index)))
      .next_u64();
}

std::vector<Finding> findings_of(const analysis::StudyAnalysis& a) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  std::vector<Finding> out;
  for (const analysis::PairwiseCell& c : a.pairwise) {
    // No participant did both settings (in this task): not a test at all.
    if (!c.p) continue;
    Finding f;
    f.method = "pairwise";
    f.task = c.task;
    f.setting = c.setting;
    f.measure = analysis::measure_column(c.measure);
    f.p = c.p.value_or(kNaN);
    f.significant = c.significant && !c.gated;
    out.push_back(std::move(f));
  }
  for (const analysis::ParticipantPairwiseCell& c : a.participant_pairwise) {
    if (!c.p) continue;
    Finding f;
    f.method = "participant_pairwise";
    f.task = c.task;
    f.setting = c.setting;
    f.measure = analysis::measure_column(c.measure);
    f.p = *c.p;
    f.significant = c.significant;
    out.push_back(std::move(f));
  }
  for (const analysis::FriedmanRow& r : a.friedman) {
    if (r.hand != -1) continue;  // the table's row: both hands as blocks
    if (!r.test.result) continue;  // fewer than 2 settings with data: no test
    Finding f;
    f.method = "participant";
    f.task = r.task;
    f.measure = analysis::measure_column(r.measure);
    f.participant = r.participant;
    f.p = r.test.result ? r.test.result->p : kNaN;
    f.significant = r.test.result && r.test.result->p < a.options.alpha;
    out.push_back(std::move(f));
  }
  return out;
}

StudyOutcome run_power_study(const protocols::Protocol& protocol, int participants, int index, std::uint64_t seed,
                             const SimulatedStudyOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  StudyOutcome o;
  o.participants = participants;
  o.index = index;
  o.seed = study_seed(seed, participants, index);
  const SimulatedStudy s = simulate_study(protocol, participants, o.seed, options);
  o.trials_run = s.trials_run;
  o.trials_timed_out = s.trials_timed_out;
  o.updates = s.updates;
  o.findings = findings_of(s.analysis);
  o.changes = changes_of(s.analysis);
  o.setting_trials = s.setting_trials;
  for (const analysis::StaircaseRow& r : s.analysis.staircases)
    o.staircases.push_back({r.participant, r.threshold, static_cast<int>(r.trials.size())});
  o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return o;
}

int draw_group(int index) { return index % kDrawGroups; }

std::size_t draw_of_group(int group, std::size_t draws) {
  return draws == 0 ? 0 : static_cast<std::size_t>(group) * draws / static_cast<std::size_t>(kDrawGroups) % draws;
}

std::vector<PowerRow> summarize_power(const std::vector<StudyOutcome>& outcomes,
                                      const std::vector<std::string>& setting_order, int draw_groups) {
  auto rank = [&](const std::string& setting) {
    const auto it = std::find(setting_order.begin(), setting_order.end(), setting);
    return static_cast<std::size_t>(it - setting_order.begin());
  };
  using Key = std::tuple<int, std::string, std::string, std::size_t, std::string, std::string>;
  std::map<Key, PowerRow> rows;
  std::map<Key, std::map<int, std::pair<int, int>>> groups;  // group -> (significant, tests)
  for (const StudyOutcome& o : outcomes) {
    for (const Finding& f : o.findings) {
      if (std::isnan(f.p)) continue;  // not computable: not a test (see findings_of)
      PowerRow& r = rows[{o.participants, f.method, f.task, rank(f.setting), f.setting, f.measure}];
      r.participants = o.participants;
      r.method = f.method;
      r.task = f.task;
      r.setting = f.setting;
      r.measure = f.measure;
      ++r.tests;
      if (f.significant) ++r.significant;
      if (draw_groups > 1) {
        auto& [hits, tests] = groups[{o.participants, f.method, f.task, rank(f.setting), f.setting, f.measure}]
                                    [draw_group(o.index) % draw_groups];
        ++tests;
        if (f.significant) ++hits;
      }
    }
  }
  std::vector<PowerRow> out = with_rates(rows, &PowerRow::significant, &PowerRow::tests);
  if (draw_groups <= 1) return out;
  for (PowerRow& r : out) {
    const auto& g = groups[{r.participants, r.method, r.task, rank(r.setting), r.setting, r.measure}];
    const double p = r.rate;
    // Between-group variance of the rates, less their sampling variance.
    double between = 0.0, sampling = 0.0;
    int used = 0;
    for (const auto& [group, counts] : g) {
      const auto [hits, tests] = counts;
      if (tests == 0) continue;
      const double rate = static_cast<double>(hits) / tests;
      between += (rate - p) * (rate - p);
      sampling += p * (1.0 - p) / tests;
      ++used;
    }
    double tau2 = 0.0;
    if (used > 1) tau2 = std::max(0.0, between / (used - 1) - sampling / used);
    // The model's spread is added in quadrature to the Wilson half-widths,
    // not to the normal approximation's: at a rate of 0 or 1 that
    // approximation has no width at all, and an interval "with the model's
    // uncertainty" must never be narrower than the sampling one alone.
    const double model_half_width = 1.96 * std::sqrt(tau2);
    r.model_low = std::max(0.0, p - std::hypot(p - r.wilson_low, model_half_width));
    r.model_high = std::min(1.0, p + std::hypot(r.wilson_high - p, model_half_width));
  }
  return out;
}

std::vector<FalsePositiveRow> false_positive_rates(const std::vector<StudyOutcome>& outcomes,
                                                   const std::set<std::string>& null_settings) {
  std::map<std::tuple<int, std::string, std::string>, FalsePositiveRow> rows;
  if (null_settings.empty()) return {};
  for (const StudyOutcome& o : outcomes) {
    // Per study: did any comparison of a null setting (any task) come out significant?
    std::map<std::pair<std::string, std::string>, bool> any;
    for (const Finding& f : o.findings) {
      if (f.method == "participant" || !null_settings.count(f.setting) || std::isnan(f.p)) continue;
      bool& hit = any[{f.method, f.measure}];
      hit = hit || f.significant;
    }
    for (const auto& [key, hit] : any) {
      FalsePositiveRow& r = rows[{o.participants, key.first, key.second}];
      r.participants = o.participants;
      r.method = key.first;
      r.measure = key.second;
      ++r.studies;
      if (hit) ++r.with_false_positive;
    }
  }
  return with_rates(rows, &FalsePositiveRow::with_false_positive, &FalsePositiveRow::studies);
}

std::vector<StaircaseSummaryRow> summarize_staircases(const std::vector<StudyOutcome>& outcomes) {
  constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
  const auto mean_sd = [kNone](const std::vector<double>& v) -> std::pair<double, double> {
    if (v.empty()) return {kNone, kNone};
    double mean = 0.0;
    for (double x : v) mean += x;
    mean /= static_cast<double>(v.size());
    if (v.size() < 2) return {mean, kNone};
    double ss = 0.0;
    for (double x : v) ss += (x - mean) * (x - mean);
    return {mean, std::sqrt(ss / static_cast<double>(v.size() - 1))};
  };
  std::map<int, std::vector<const StudyOutcome*>> by_size;
  for (const StudyOutcome& o : outcomes)
    if (!o.staircases.empty()) by_size[o.participants].push_back(&o);
  std::vector<StaircaseSummaryRow> rows;
  for (const auto& [participants, studies] : by_size) {
    StaircaseSummaryRow r;
    r.participants = participants;
    r.studies = static_cast<int>(studies.size());
    std::vector<double> thresholds, study_means;
    double trials = 0.0;
    for (const StudyOutcome* o : studies) {
      std::vector<double> mine;
      for (const StaircaseOutcome& s : o->staircases) {
        ++r.staircases;
        trials += s.trials;
        if (s.threshold) mine.push_back(*s.threshold);
      }
      r.with_threshold += static_cast<int>(mine.size());
      thresholds.insert(thresholds.end(), mine.begin(), mine.end());
      if (!mine.empty()) study_means.push_back(mean_sd(mine).first);
    }
    r.rate = static_cast<double>(r.with_threshold) / r.staircases;
    const analysis::ProportionInterval ci = analysis::wilson_interval(r.with_threshold, r.staircases);
    r.wilson_low = ci.low;
    r.wilson_high = ci.high;
    std::tie(r.mean_threshold, r.sd_between_participants) = mean_sd(thresholds);
    r.sd_of_study_means = mean_sd(study_means).second;
    r.mean_trials = trials / r.staircases;
    rows.push_back(r);
  }
  return rows;
}

}  // namespace hapticlab::planning
