#include "analysis/study/statistics_tables.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <utility>

#include "analysis/stats/balanced_pair.h"
#include "analysis/stats/block_table.h"
#include "analysis/stats/data_error.h"
#include "analysis/stats/durbin.h"
#include "analysis/stats/effect_size.h"
#include "analysis/stats/percentile.h"
#include "analysis/stats/friedman.h"
#include "analysis/stats/pairwise_friedman.h"
#include "analysis/stats/skillings_mack.h"
#include "analysis/study/ordered_names.h"
#include "analysis/study/dose_response.h"
#include "analysis/study/ks_tables.h"
#include "analysis/study/participant_level.h"

namespace hapticlab::analysis {

// ---------------------------------------------------------------------------
// Statistics
// ---------------------------------------------------------------------------
namespace {

struct Point {
  std::string block;
  std::string setting;
  int repetition = 0;
  int position = 0;
  double value = 0.0;
};

// Finite values of one measure, for the trials matching the filters
// (empty participant: every participant; hand -1 with a per-hand measure:
// both hands, each its own block "participant/hand").
std::vector<Point> collect(const StudyAnalysis& a, const std::string& participant, const std::string& task,
                           Measure m, int hand) {
  std::vector<Point> out;
  for (const TrialRecord& t : a.trials) {
    if (t.task != task || (!participant.empty() && t.participant != participant)) continue;
    if (!measure_per_hand(m)) {
      const double v = t.value(m, 0);
      if (std::isfinite(v)) out.push_back({t.participant, t.setting, t.repetition, t.position, v});
      continue;
    }
    for (int h = 0; h < 2; ++h) {
      if (hand >= 0 && h != hand) continue;
      const double v = t.value(m, h);
      if (std::isfinite(v)) out.push_back({t.participant + "/" + hand_name(h), t.setting, t.repetition, t.position, v});
    }
  }
  // Replicates in repetition order, so balancing keeps the first ones.
  std::stable_sort(out.begin(), out.end(), [](const Point& x, const Point& y) { return x.repetition < y.repetition; });
  return out;
}

std::vector<std::string> ordered_settings(const StudyAnalysis& a, const std::vector<Point>& points) {
  std::vector<std::string> out;
  for (const auto& s : a.settings)
    if (std::any_of(points.begin(), points.end(), [&](const Point& p) { return p.setting == s; })) out.push_back(s);
  return out;
}

// Friedman with replicates across the settings present, after making the
// design rectangular: settings missing from a block are dropped, and every
// cell keeps its first r repetitions, r the smallest count (MATLAB's
// friedman(X, reps) needs equal replicates).
OptionalTest balanced_friedman(const StudyAnalysis& a, const std::vector<Point>& points) {
  OptionalTest out;
  std::vector<std::string> blocks;
  for (const auto& p : points) add_unique(blocks, p.block);
  std::map<std::pair<std::string, std::string>, std::vector<double>> cells;
  for (const auto& p : points) cells[{p.block, p.setting}].push_back(p.value);
  std::vector<std::string> dropped_settings;
  for (const auto& s : ordered_settings(a, points)) {
    const bool everywhere = std::all_of(blocks.begin(), blocks.end(), [&](const std::string& b) { return cells.count({b, s}) > 0; });
    if (everywhere) {
      out.settings.push_back(s);
    } else {
      dropped_settings.push_back(s);
    }
  }
  if (out.settings.size() < 2) {
    out.note = points.empty() ? "no data" : "fewer than 2 settings with data in every block";
    return out;
  }
  std::size_t r = std::numeric_limits<std::size_t>::max();
  for (const auto& b : blocks)
    for (const auto& s : out.settings) r = std::min(r, cells[{b, s}].size());
  BlockTable table;
  table.block_names = blocks;
  table.treatment_names = out.settings;
  for (const auto& b : blocks) {
    auto& row = table.cells.emplace_back();
    for (const auto& s : out.settings) {
      const auto& v = cells[{b, s}];
      out.dropped += v.size() - r;
      row.emplace_back(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(r));
    }
  }
  for (const auto& s : dropped_settings)
    for (const auto& b : blocks) out.dropped += cells.count({b, s}) ? cells[{b, s}].size() : 0;
  out.replicates = r;
  try {
    out.result = friedman_test(table);
    out.kendalls_w = kendalls_w(out.result->statistic, table.block_names.size(), out.settings.size(), r);
  } catch (const DataError& e) {
    out.note = e.what();
  }
  if (!dropped_settings.empty()) {
    std::string names;
    for (const auto& s : dropped_settings) names += (names.empty() ? "" : ", ") + s;
    out.note += (out.note.empty() ? "" : "; ") + std::string("left out (missing in a block): ") + names;
  }
  return out;
}

double median_of(std::vector<double> v, PercentileMethod method) {
  std::sort(v.begin(), v.end());
  return percentile_sorted(v, 50.0, method);
}

OptionalTest whole_design_test(const StudyAnalysis& a, const std::vector<Point>& points) {
  OptionalTest out;
  std::vector<std::string> blocks;
  for (const auto& p : points) add_unique(blocks, p.block);
  out.settings = ordered_settings(a, points);
  if (out.settings.size() < 2 || blocks.size() < 2) {
    out.note = "needs >= 2 blocks and >= 2 settings";
    return out;
  }
  std::map<std::pair<std::string, std::string>, std::vector<double>> cells;
  for (const auto& p : points) cells[{p.block, p.setting}].push_back(p.value);
  // One value per cell: the median of its repetitions (Durbin and
  // Skillings–Mack take no replicates).
  BlockTable table;
  table.block_names = blocks;
  table.treatment_names = out.settings;
  bool complete = true;
  for (const auto& b : blocks) {
    auto& row = table.cells.emplace_back();
    for (const auto& s : out.settings) {
      auto it = cells.find({b, s});
      if (it == cells.end()) {
        complete = false;
        row.emplace_back();
      } else {
        row.push_back({median_of(it->second, a.options.percentile_method)});
      }
    }
  }
  out.replicates = 1;
  try {
    if (complete) {
      out.result = friedman_test(table);
      out.kendalls_w = kendalls_w(out.result->statistic, blocks.size(), out.settings.size(), 1);
    } else {
      try {
        out.result = durbin_test(table).chi_square;
      } catch (const DataError&) {
        // Not a balanced incomplete block design: Skillings–Mack takes any pattern.
        out.result = skillings_mack_test(table);
      }
    }
  } catch (const DataError& e) {
    out.note = e.what();
  }
  return out;
}

// Table 3.4: per participant and task, hands as blocks; then each hand alone.
void friedman_per_participant(StudyAnalysis& a) {
  for (const auto& task : a.tasks) {
    for (const auto& participant : a.participants) {
      const bool did_task = std::any_of(a.trials.begin(), a.trials.end(), [&](const TrialRecord& t) {
        return t.participant == participant && t.task == task;
      });
      if (!did_task) continue;
      for (int hand = -1; hand < 2; ++hand) {
        for (Measure m : kAllMeasures) {
          if (hand >= 0 && !measure_per_hand(m)) continue;
          FriedmanRow row{participant, task, m, hand, {}};
          row.test = balanced_friedman(a, collect(a, participant, task, m, hand));
          a.friedman.push_back(std::move(row));
        }
      }
    }
  }
}

// The control against `setting` for one task and measure, over all blocks
// that did both (a cell of Tables 3.5 / 3.6).
PairwiseCell pairwise_cell(const StudyAnalysis& a, const std::string& task, const std::string& setting, Measure m) {
  const AnalysisOptions& o = a.options;
  PairwiseCell cell;
  cell.task = task;
  cell.setting = setting;
  cell.measure = m;
  cell.gated = std::none_of(a.friedman.begin(), a.friedman.end(), [&](const FriedmanRow& r) {
    return r.task == task && r.measure == m && r.hand == -1 && r.test.result && r.test.result->p < o.alpha;
  });
  const std::vector<Point> points = collect(a, "", task, m, -1);
  std::vector<Observation> pair_points;
  for (const auto& p : points) {
    if (p.setting == a.control || p.setting == setting) pair_points.push_back({p.block, p.setting, "", p.value});
  }
  // Balanced as `stats pairwise` does: same replicates in every cell.
  const BlockTable both = BlockTable::from_observations(pair_points);
  const BalancedPair balanced =
      both.treatment_count() == 2
          ? balance_pair(both, both.treatment_index(a.control), both.treatment_index(setting))
          : BalancedPair{};
  const BlockTable& table = balanced.table;
  std::set<std::string> participants;
  for (const auto& b : table.block_names) participants.insert(b.substr(0, b.find('/')));
  cell.note = balanced.note();
  cell.blocks = table.block_names.size();
  cell.participants = participants.size();
  if (table.block_names.empty()) {
    cell.note = "no participant has data for both settings";
    return cell;
  }
  try {
    const TestResult r = friedman_test(table);
    cell.p = r.p;
    cell.statistic = r.statistic;
    cell.significant = r.p < a.sidak_level;
    // Effect size over the same blocks: each block's median under
    // the setting minus its median under the control.
    cell.rank_biserial =
        paired_rank_biserial(table, table.treatment_index(a.control), table.treatment_index(setting));
    cell.direction = *cell.rank_biserial > 0 ? "higher" : *cell.rank_biserial < 0 ? "lower" : "equal";
  } catch (const DataError& e) {
    cell.note = e.what();
  }
  return cell;
}

// What the tests are about: each setting's median and IQR per task.
void descriptive_rows(StudyAnalysis& a) {
  const AnalysisOptions& o = a.options;
  for (const auto& task : a.tasks) {
    for (const auto& setting : a.settings) {
      for (Measure m : kAllMeasures) {
        DescriptiveRow d;
        d.task = task;
        d.setting = setting;
        d.measure = m;
        std::vector<double> v;
        for (const Point& p : collect(a, "", task, m, -1))
          if (p.setting == setting) v.push_back(p.value);
        d.n = v.size();
        d.median = d.q1 = d.q3 = std::numeric_limits<double>::quiet_NaN();
        if (!v.empty()) {
          std::sort(v.begin(), v.end());
          d.q1 = percentile_sorted(v, 25.0, o.percentile_method);
          d.median = percentile_sorted(v, 50.0, o.percentile_method);
          d.q3 = percentile_sorted(v, 75.0, o.percentile_method);
        }
        a.descriptive.push_back(d);
      }
    }
  }
}

// Table 3.7: trial-number correlations.
void trial_correlations(StudyAnalysis& a) {
  for (const auto& task : a.tasks) {
    for (const auto& participant : a.participants) {
      for (Measure m : kAllMeasures) {
        for (int hand = measure_per_hand(m) ? 0 : -1; hand < (measure_per_hand(m) ? 2 : 0); ++hand) {
          CorrelationRow row;
          row.participant = participant;
          row.task = task;
          row.measure = m;
          row.hand = hand;
          for (const TrialRecord& t : a.trials) {
            if (t.participant != participant || t.task != task) continue;
            const double v = t.value(m, std::max(hand, 0));
            if (!std::isfinite(v)) continue;
            row.trial_numbers.push_back(t.position);
            row.values.push_back(v);
            row.settings.push_back(t.setting);
          }
          if (row.values.empty()) continue;  // the participant did not do this task
          if (row.values.size() < 3) {
            row.note = "fewer than 3 trials";
          } else {
            try {
              row.result = pearson_correlation(row.trial_numbers, row.values);
            } catch (const DataError& e) {
              row.note = e.what();
            }
          }
          a.correlations.push_back(std::move(row));
        }
      }
    }
  }
}

}  // namespace

void run_statistics(StudyAnalysis& a) {
  a.friedman.clear();
  a.pairwise.clear();
  a.participant_pairwise.clear();
  a.whole_design.clear();
  a.correlations.clear();
  a.ks.clear();
  const AnalysisOptions& o = a.options;

  friedman_per_participant(a);

  // Tables 3.5 / 3.6: the control against each other setting, all blocks that did both.
  a.sidak_m = a.settings.empty() ? 0 : a.settings.size() - 1;
  a.sidak_level = a.sidak_m > 0 ? sidak_level(o.alpha, a.sidak_m) : o.alpha;
  for (const auto& task : a.tasks) {
    for (std::size_t si = 1; si < a.settings.size(); ++si) {
      for (Measure m : kAllMeasures) a.pairwise.push_back(pairwise_cell(a, task, a.settings[si], m));
    }
  }

  // The same comparisons with one value per participant (the default method).
  a.participant_pairwise = participant_pairwise(a);
  // A dose-response study: the trend over strengths and the smallest that changes the measure.
  a.dose_response = dose_response(a);

  a.descriptive.clear();
  descriptive_rows(a);

  // Whole design: every participant at once.
  for (const auto& task : a.tasks) {
    for (Measure m : kAllMeasures) {
      a.whole_design.push_back({task, m, whole_design_test(a, collect(a, "", task, m, -1))});
    }
  }

  trial_correlations(a);

  // Appendix I: KS with the moving block bootstrap, control vs each setting.
  if (o.ks) add_ks_rows(a, o.threads);
}

}  // namespace hapticlab::analysis
