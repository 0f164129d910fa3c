// The report's summary and comparison tables: Friedman, pairwise, per participant, whole design.
#include "analysis/study/headline_format.h"
#include "analysis/report/report_parts.h"

#include <algorithm>
#include <functional>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "analysis/report/box_stats.h"
#include "analysis/report/gnuplot.h"
#include "core/common/utc_time.h"
#include "core/settings/settings_json.h"
#include "analysis/stats/data_error.h"
#include "analysis/stats/sign_flip.h"
#include "core/common/build_info.h"
#include "core/common/output_file.h"

namespace hapticlab::analysis::report_parts {

std::vector<std::string> measure_header(const std::string& first) {
  std::vector<std::string> h{first};
  for (Measure m : kAllMeasures) h.emplace_back(measure_label(m));
  return h;
}

Cell p_cell(const std::optional<TestResult>& r, double level) {
  if (!r) return {"N/A", false};
  return {format_p(r->p, level), r->p < level};
}


// The analysis options as `hapticlab analyze` takes them, so a reader can rerun it.
std::string analysis_options_text(const AnalysisOptions& o) {
  std::string out = "alpha " + num(o.alpha) + ", control '" + (o.control_setting.empty() ? "auto" : o.control_setting) +
                    "', percentile " + std::string(percentile_method_name(o.percentile_method)) + ", contact " +
                    num(o.min_force_N * 1e3) + " mN, aborted trials " + (o.include_aborted ? "included" : "left out");
  if (o.ks) {
    out += ", KS bootstrap: " + std::to_string(o.ks_resamples) + " resamples, stride " + std::to_string(o.ks_stride) +
           ", block " + std::to_string(o.ks_block_length) + ", seed " + std::to_string(o.seed);
  } else {
    out += ", KS bootstrap off";
  }
  return out + ", CDF points " + std::to_string(o.cdf_points);
}

Section summary_section(const StudyAnalysis& a) {
  Section s;
  s.title = "Study and data";
  const TrialCounts& c = a.counts;
  Table t;
  t.header = {"Item", "Value"};
  t.rows = {{{"Study"}, {a.study_name + " (id " + std::to_string(a.study_id) + ")"}},
            {{"Study created (UTC)"}, {a.study_created_utc}},
            {{"Study created by"}, {a.study_software_version}},
            {{"Study seed"}, {std::to_string(a.study_seed)}},
            {{"Protocol SHA-256"}, {a.protocol_sha256}},
            {{"Report written by"}, {software_version()}},
            {{"Report written (UTC)"}, {utc_now_iso8601()}},
            {{"Analysis options"}, {analysis_options_text(a.options)}},
            {{"Database"}, {a.db_path.string()}},
            {{"Participants"}, {std::to_string(a.participants.size())}},
            {{"Tasks"}, {std::to_string(a.tasks.size())}},
            {{"Settings"}, {std::to_string(a.settings.size()) + " (control: " + a.control + ")"}},
            {{"Haptic loop rate"}, {a.session_conditions.rate_text}},
            {{"Who held the device"}, {a.session_conditions.participant_text}},
            {{"Trials analysed"}, {std::to_string(c.analysed)}},
            {{"Complete trials"}, {std::to_string(c.complete)}},
            {{"Aborted trials left out"}, {std::to_string(c.aborted_excluded)}},
            {{"Aborted trials included"}, {std::to_string(c.aborted_included)}},
            {{"Trials not run (planned or running)"}, {std::to_string(c.not_run)}},
            {{"Analysed trials without a task window"}, {std::to_string(c.without_window)}},
            {{"Percentile definition"}, {std::string(percentile_method_name(a.options.percentile_method))}},
            {{"Contact threshold |F|"}, {num(a.options.min_force_N * 1e3) + " mN"}},
            {{"Significance level alpha"}, {num(a.options.alpha)}}};
  s.tables.push_back(std::move(t));
  s.intro = (c.aborted_excluded == 1 ? std::string("1 aborted trial was") : std::to_string(c.aborted_excluded) + " aborted trials were") + " left out" +
            (a.options.include_aborted ? " (none: --include-aborted was given)" : "") +
            ". Measures are computed over each trial's task window, from the first 20 mm insertion to the last "
            "tissue contact; the per-trial values are in metrics.csv.";
  for (const std::string& w : a.session_conditions.warnings) s.intro += " Warning: " + w + ".";
  std::size_t gapped = 0;
  for (const auto& tr : a.trials) gapped += !tr.note.empty();
  if (gapped > 0)
    s.intro += " " + std::to_string(gapped) + (gapped == 1 ? " trial has" : " trials have") +
               " updates missing from its samples (a full queue): path length and energy, which would bridge a "
               "gap with one straight step, are left out there (metrics.csv's note says which).";
  if (c.without_window > 0) {
    Table w;
    w.title = "Trials without measures";
    w.header = {"Trial", "Participant", "Task", "Setting", "Repetition", "Why"};
    for (const auto& tr : a.trials)
      if (!tr.window)
        w.rows.push_back({{std::to_string(tr.trial_id)}, {tr.participant}, {tr.task}, {tr.setting},
                          {std::to_string(tr.repetition)}, {tr.problem}});
    s.tables.push_back(std::move(w));
  }
  return s;
}

Section friedman_section(const StudyAnalysis& a) {
  Section s;
  s.title = "Table 3.4: Friedman test per participant";
  s.intro = "P values of intra-participant Friedman tests across settings: hands are the blocks, repetitions the "
            "replicates ranked within each block (completion time: one block per participant). Bold: p < " +
            num(a.options.alpha) + ".";
  // One row per task and participant, a cell per measure from that
  // participant's Table 3.4 test (both hands as blocks).
  auto per_participant = [&](const std::function<Cell(const FriedmanRow&)>& cell_of) {
    Table t;
    t.header = measure_header("");
    for (const auto& task : a.tasks) {
      for (const auto& participant : a.participants) {
        std::vector<Cell> row{{task + " " + participant}};
        bool any = false;
        for (Measure m : kAllMeasures) {
          Cell cell{"N/A"};
          for (const auto& r : a.friedman) {
            if (r.task != task || r.participant != participant || r.hand != -1 || r.measure != m) continue;
            any = true;
            cell = cell_of(r);
          }
          row.push_back(cell);
        }
        if (any) t.rows.push_back(std::move(row));
      }
    }
    return t;
  };
  std::string notes;
  Table t = per_participant([&](const FriedmanRow& r) {
    if (r.test.dropped > 0 || !r.test.note.empty()) {
      notes += r.task + " " + r.participant + " " + measure_label(r.measure) + ": " +
               (r.test.dropped > 0 ? std::to_string(r.test.dropped) + " observation(s) dropped to balance to " +
                                         std::to_string(r.test.replicates) + " replicate(s)"
                                   : std::string()) +
               (r.test.dropped > 0 && !r.test.note.empty() ? "; " : "") + r.test.note + ". ";
    }
    return p_cell(r.test.result, a.options.alpha);
  });
  t.note = notes;
  s.tables.push_back(std::move(t));

  // Effect sizes of the same tests.
  Table w = per_participant([](const FriedmanRow& r) {
    return r.test.kendalls_w ? Cell{num(*r.test.kendalls_w, "%.2f")} : Cell{"N/A"};
  });
  w.title = "Effect size: Kendall's W";
  w.note = "Kendall's W: how alike the blocks rank the settings, 0 (not at all) to 1 (every block the same); "
           "with replicates, the Friedman statistic over its largest possible value (docs/analysis.md).";
  s.tables.push_back(std::move(w));

  Table h;
  h.title = "Per hand";
  h.header = {"Task", "Participant", "Hand"};
  for (Measure m : kAllMeasures)
    if (measure_per_hand(m)) h.header.emplace_back(measure_label(m));
  for (const auto& task : a.tasks) {
    for (const auto& participant : a.participants) {
      for (int hand = 0; hand < 2; ++hand) {
        std::vector<Cell> row{{task}, {participant}, {hand_name(hand)}};
        for (Measure m : kAllMeasures) {
          if (!measure_per_hand(m)) continue;
          for (const auto& r : a.friedman)
            if (r.task == task && r.participant == participant && r.hand == hand && r.measure == m)
              row.push_back(p_cell(r.test.result, a.options.alpha));
        }
        if (row.size() > 3) h.rows.push_back(std::move(row));
      }
    }
  }
  s.tables.push_back(std::move(h));
  return s;
}

Section pairwise_section(const StudyAnalysis& a, const std::string& task) {
  Section s;
  s.title = thesis_pairwise_table(task) + ": " + a.control + " compared to each setting, " + task +
            " (the thesis' procedure)";
  s.intro = "P values of pairwise Friedman tests between " + a.control +
            " and each other setting over every participant (and hand) who did both; the number in brackets is "
            "the number of participants. Bold: significant at the Šidák level 1-(1-alpha)^(1/m) = " +
            format_level(a.sidak_level) + " for m = " + std::to_string(a.sidak_m) +
            ". A p value in parentheses was computed although no participant's Table 3.4 test was significant "
            "for that measure (the thesis did not compare those).";
  Table t;
  t.header = measure_header(a.control + " compared to:");
  for (std::size_t si = 1; si < a.settings.size(); ++si) {
    std::size_t participants = 0;
    for (const auto& c : a.pairwise)
      if (c.task == task && c.setting == a.settings[si]) participants = std::max(participants, c.participants);
    std::vector<Cell> row{{a.settings[si] + " (" + std::to_string(participants) + ")"}};
    for (Measure m : kAllMeasures) {
      Cell cell{"N/A"};
      for (const auto& c : a.pairwise) {
        if (c.task != task || c.setting != a.settings[si] || c.measure != m || !c.p) continue;
        const std::string p = format_p(*c.p, a.sidak_level);
        cell = {c.gated ? "(" + p + ")" : p, c.significant};
      }
      row.push_back(cell);
    }
    t.rows.push_back(std::move(row));
  }
  for (const auto& c : a.pairwise) {
    if (c.task != task || c.note.empty()) continue;
    t.note += c.setting + " " + measure_label(c.measure) + ": " + c.note + ". ";
  }
  s.tables.push_back(std::move(t));

  // Effect size and direction of the same comparisons.
  Table e;
  e.title = "Effect size: matched-pairs rank-biserial r, and direction";
  e.header = measure_header(a.control + " compared to:");
  for (std::size_t si = 1; si < a.settings.size(); ++si) {
    std::vector<Cell> row{{a.settings[si]}};
    for (Measure m : kAllMeasures) {
      Cell cell{"N/A"};
      for (const auto& c : a.pairwise)
        if (c.task == task && c.setting == a.settings[si] && c.measure == m && c.rank_biserial)
          cell = {(*c.rank_biserial > 0 ? "+" : "") + num(*c.rank_biserial, "%.2f") + " " + c.direction};
      row.push_back(cell);
    }
    e.rows.push_back(std::move(row));
  }
  e.note = "r over the test's blocks (participant and hand) of the setting's median minus " + a.control +
           "'s: +1 when every block is higher under the setting, -1 when every block is lower (Kerby 2014).";
  s.tables.push_back(std::move(e));

  // What the p values are about.
  Table d;
  d.title = "Median [Q1, Q3] per setting";
  d.header = {"Setting"};
  for (Measure m : kAllMeasures) d.header.push_back(std::string(measure_label(m)) + " [" + measure_unit(m) + "]");
  for (const std::string& setting : a.settings) {
    std::vector<Cell> row{{setting}};
    bool any = false;
    for (Measure m : kAllMeasures) {
      Cell cell{"N/A"};
      for (const auto& r : a.descriptive)
        if (r.task == task && r.setting == setting && r.measure == m && r.n > 0) {
          cell = {num(r.median) + " [" + num(r.q1) + ", " + num(r.q3) + "]"};
          any = true;
        }
      row.push_back(cell);
    }
    if (any) d.rows.push_back(std::move(row));
  }
  d.note = "Every analysed trial of the task (and both hands for per-hand measures) pooled; percentiles as "
           "the analysis computes them (" + std::string(percentile_method_name(a.options.percentile_method)) + ").";
  s.tables.push_back(std::move(d));
  return s;
}

// What the sign-flip test can reach in this study: with n participants
// its smallest p is 2/2^n, against the Šidák level of m comparisons at
// alpha; computed from the task's comparisons, whose participant counts
// may differ (an incomplete design).
std::string participant_reach_sentence(const StudyAnalysis& a, const std::string& task) {
  std::size_t fewest = 0, most = 0;
  bool any = false;
  for (const auto& c : a.participant_pairwise) {
    if (c.task != task || !c.p) continue;
    fewest = any ? std::min(fewest, c.participants) : c.participants;
    most = std::max(most, c.participants);
    any = true;
  }
  const std::size_t needed = sign_flip_differences_needed(a.sidak_level);
  const auto smallest = [](std::size_t n) { return num(sign_flip_smallest_p(n), "%.2g"); };
  std::string out = "With n participants the smallest p the test can give is 2/2^n; the level " +
                    format_level(a.sidak_level) + " (alpha " + num(a.options.alpha) + ", m = " +
                    std::to_string(a.sidak_m) + " comparisons) needs " +
                    (needed == 0 ? std::string("more participants than the test can count")
                                 : "at least " + std::to_string(needed) + " (2/2^" + std::to_string(needed) + " = " +
                                       smallest(needed) + ")") +
                    ".";
  if (!any) return out;
  const std::string count = fewest == most ? std::to_string(most) : std::to_string(fewest) + " to " + std::to_string(most);
  out += " In this task the comparisons have " + count + " participants";
  if (needed != 0 && fewest >= needed)
    return out + " (smallest p " + smallest(fewest) +
           "), so one in which every participant differs in the same direction reaches it.";
  if (needed == 0 || most < needed)
    return out + " (smallest p " + smallest(most) + "), so none can reach it, whatever the data.";
  return out + ": one with fewer than " + std::to_string(needed) +
         " (the number in brackets) cannot reach it, whatever the data.";
}

// Each setting against the control with one value per participant
// (analysis/study/participant_level.h), the default method.
Section participant_section(const StudyAnalysis& a, const std::string& task) {
  Section s;
  const bool first = a.options.method == ComparisonMethod::kParticipant;
  s.title = a.control + " compared to each setting, one value per participant, " + task;
  s.intro = std::string(first ? "The recommended comparison (analyze --method participant, the default; "
                                "docs/analysis.md, \"Which comparison\"). "
                              : "Beside the thesis' procedure (this report was made with --method thesis). ") +
            "Each participant's median over their repetitions (and both hands, for per-hand measures) under "
            "each setting; their differences from the same participant's median under " + a.control +
            " tested with the exact sign-flip permutation test, so a participant counts once however many "
            "trials they did. Bold: significant at the Šidák level " + format_level(a.sidak_level) + ". " +
            participant_reach_sentence(a, task);
  Table t;
  t.header = measure_header(a.control + " compared to:");
  Table d;
  d.title = "Mean difference over participants (setting minus " + a.control + ")";
  d.header = {"Setting"};
  for (Measure m : kAllMeasures) d.header.push_back(std::string(measure_label(m)) + " [" + measure_unit(m) + "]");
  for (std::size_t si = 1; si < a.settings.size(); ++si) {
    std::size_t participants = 0;
    for (const auto& c : a.participant_pairwise)
      if (c.task == task && c.setting == a.settings[si]) participants = std::max(participants, c.participants);
    std::vector<Cell> row{{a.settings[si] + " (" + std::to_string(participants) + ")"}};
    std::vector<Cell> diff{{a.settings[si]}};
    for (Measure m : kAllMeasures) {
      Cell cell{"N/A"};
      Cell mean{"N/A"};
      for (const auto& c : a.participant_pairwise)
        if (c.task == task && c.setting == a.settings[si] && c.measure == m && c.p) {
          cell = {format_p(*c.p, a.sidak_level), c.significant};
          if (c.mean_difference) mean = {(*c.mean_difference > 0 ? "+" : "") + num(*c.mean_difference)};
        }
      row.push_back(cell);
      diff.push_back(mean);
    }
    t.rows.push_back(std::move(row));
    d.rows.push_back(std::move(diff));
  }
  t.note = "The number in brackets: participants with data under both settings.";
  s.tables.push_back(std::move(t));
  s.tables.push_back(std::move(d));
  return s;
}

Section whole_design_section(const StudyAnalysis& a) {
  Section s;
  s.title = "All participants at once";
  s.intro = "Beyond the thesis: one test over every participant (and hand) per task and measure, each cell the "
            "median of its repetitions. A complete design gets the Friedman test, a balanced incomplete one "
            "Durbin's test, any other pattern of missing cells the Skillings-Mack test. Bold: p < " +
            num(a.options.alpha) + ".";
  Table t;
  t.header = {"Task", "Measure", "Test", "Statistic", "df", "p", "Blocks", "Note"};
  for (const auto& r : a.whole_design) {
    if (r.test.result) {
      const TestResult& x = *r.test.result;
      t.rows.push_back({{r.task}, {measure_label(r.measure)}, {x.method}, {num(x.statistic, "%.4g")},
                        {num(x.df, "%.0f")}, p_cell(x, a.options.alpha), {std::to_string(x.blocks)}, {r.test.note}});
    } else {
      t.rows.push_back({{r.task}, {measure_label(r.measure)}, {"N/A"}, {""}, {""}, {"N/A"}, {""}, {r.test.note}});
    }
  }
  s.tables.push_back(std::move(t));
  return s;
}

}  // namespace hapticlab::analysis::report_parts
