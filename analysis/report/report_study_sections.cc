// The report's other tables: correlations with the trial number, dose-response, staircase, sites, energy, KS.
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

std::string correlation_hand(const CorrelationRow& r) { return r.hand < 0 ? "both" : hand_name(r.hand); }

// "1 trial", "2 trials".
std::string count_of(std::size_t n, const std::string& noun) {
  return std::to_string(n) + " " + noun + (n == 1 ? "" : "s");
}

// The legends name settings by their initials (HF, NFF, I+B): each figure
// section says what they stand for.
std::string abbreviation_key(const std::vector<std::string>& settings) {
  std::string key;
  for (const auto& name : settings) {
    const std::string a = setting_abbreviation(name);
    if (a == name) continue;
    key += (key.empty() ? "" : "; ") + a + " = " + name;
  }
  return key.empty() ? key : "Legend abbreviations: " + key + ".";
}

Section correlation_section(const StudyAnalysis& a, const ReportOptions& report_options) {
  Section s;
  s.title = "Table 3.7: Correlations with the trial number";
  s.intro = "Pearson r between each measure and the trial number (the trial's position in the participant's "
            "schedule), with its two-sided p. A correlation is called strong when |r| >= 0.7 and weak when "
            "0.3 <= |r| < 0.7, and only when p < " + num(a.options.alpha) +
            "; a non-significant r gets no label. The figures of measures against trial number show |r| >= " +
            num(report_options.correlation_plot_min_abs_r) + ", significant or not.";
  Table t;
  t.title = "Significant strong and weak correlations";
  t.header = {"Perf. measure", "Task", "Participant", "Hand", "R", "P", "Strength"};
  Table all;
  all.title = "All correlations";
  all.header = t.header;
  all.header.emplace_back("n");
  all.header.emplace_back("Note");
  for (const auto& r : a.correlations) {
    if (r.result) {
      // A label for r says the trend is there; without significance it may be noise.
      const bool significant = r.result->p < a.options.alpha;
      const std::string strength = significant && r.result->strength != CorrelationStrength::kNone
                                       ? std::string(correlation_strength_name(r.result->strength))
                                       : std::string(significant ? "" : "n.s.");
      std::vector<Cell> row{{measure_label(r.measure)}, {r.task}, {r.participant}, {correlation_hand(r)},
                            {num(r.result->r, "%.2f")}, {format_p(r.result->p, a.options.alpha)},
                            {strength, significant && r.result->strength == CorrelationStrength::kStrong}};
      if (significant && r.result->strength != CorrelationStrength::kNone) t.rows.push_back(row);
      row.push_back({std::to_string(r.result->n)});
      row.push_back({r.note});
      all.rows.push_back(std::move(row));
    } else {
      all.rows.push_back({{measure_label(r.measure)}, {r.task}, {r.participant}, {correlation_hand(r)}, {"N/A"},
                          {"N/A"}, {""}, {std::to_string(r.values.size())}, {r.note}});
    }
  }
  if (t.rows.empty()) t.note = "No significant correlation reached |r| >= 0.3.";
  s.tables.push_back(std::move(t));
  s.tables.push_back(std::move(all));
  return s;
}

// Energy the device exchanged with the hands per setting (device_energy.h):
// a device that gives a hand more than it takes went unstable somewhere.
// A dose-response study (analysis/study/dose_response.h): the trend over
// strengths and the smallest strength that changes each measure.
Section dose_response_section(const StudyAnalysis& a, const std::string& task) {
  Section s;
  const DoseSeries& dose = *a.dose;
  const std::string unit = split_settings_field(dose.field).back();
  s.title = "Dose-response, " + task;
  s.intro = "The strengths of " + dose.field + ", " + a.control + " as " + num(dose.levels.front().strength) +
            ". Each participant's median over their repetitions (and both hands, for per-hand measures) at "
            "each strength; the least-squares slope of those medians on the strength, per participant; the "
            "slopes tested against zero with the exact sign-flip test over participants. The smallest "
            "significant strength: each strength against " + a.control + " (the participant-level p), tested "
            "from the strongest down at alpha " + num(a.options.alpha) + " and stopped at the first that is not "
            "significant (fixed sequence, Hsu & Berger 1999), so no Šidák correction is needed among the "
            "strengths. In the trend table, bold: p < " + num(a.options.alpha) + ".";
  Table trend;
  trend.header = {"Measure", "Mean slope [unit per " + unit + "]", "Participants", "p (trend)",
                  "Smallest significant strength"};
  Table medians;
  medians.title = "Median over participants of each participant's median, and p against " + a.control +
                  " (unadjusted); bold: the strengths the fixed-sequence procedure accepts";
  medians.header = {"Measure"};
  for (const DoseLevel& level : dose.levels) medians.header.push_back(num(level.strength));
  for (const DoseResponseRow& r : a.dose_response) {
    if (r.task != task) continue;
    const std::string label = std::string(measure_label(r.measure)) + " [" + measure_unit(r.measure) + "]";
    trend.rows.push_back({{label},
                          {r.trend_p ? (r.mean_slope > 0 ? "+" : "") + num(r.mean_slope) : "N/A"},
                          {std::to_string(r.slopes)},
                          {r.trend_p ? format_p(*r.trend_p, a.options.alpha) : "N/A", r.trend_significant},
                          {r.smallest_significant_strength ? num(*r.smallest_significant_strength) : "none"}});
    std::vector<Cell> row{{label}};
    for (std::size_t i = 0; i < r.level_medians.size(); ++i) {
      std::string text = std::isfinite(r.level_medians[i]) ? num(r.level_medians[i]) : "N/A";
      // The procedure accepts every strength from the strongest down to the
      // smallest significant one; a p below alpha under a strength it never
      // reached (it stopped above) is not a finding.
      const bool accepted = i > 0 && r.smallest_significant_strength &&
                            dose.levels[i].strength >= *r.smallest_significant_strength;
      if (i < r.p_vs_control.size() && r.p_vs_control[i]) text += " (p " + format_p(*r.p_vs_control[i]) + ")";
      row.push_back({text, accepted});
    }
    medians.rows.push_back(std::move(row));
  }
  trend.note = "Participants: those with data at two or more strengths. With n participants the smallest possible "
               "p is 2/2^n: 0.0625 for 5, 0.031 for 6.";
  medians.note = "Bold: the strengths the fixed-sequence procedure accepts, from the strongest down to the "
                 "smallest significant strength of the table above; each p is that strength against " + a.control +
                 " alone, unadjusted, so a p below " + num(a.options.alpha) + " under a strength the procedure did "
                 "not reach is not bold.";
  s.tables.push_back(std::move(trend));
  s.tables.push_back(std::move(medians));
  return s;
}

// An adaptive staircase (analysis/study/staircase_progress.h): each
// participant's threshold and how the staircase got there.
Section staircase_section(const StudyAnalysis& a) {
  Section s;
  const protocols::StaircaseSpec& sp = *a.staircase;
  s.title = "Adaptive staircase";
  s.intro = "The strength of " + sp.field + " at which " + sp.measure + " changes (" +
            std::string(protocols::change_direction_name(sp.direction)) + ") by " + num(100.0 * sp.change) +
            " % from each participant's median under " + sp.baseline + ", in " + sp.task + ": a " +
            std::to_string(sp.down) + "-down-1-up staircase (Levitt 1971) from " + num(sp.start) + " in steps of " +
            num(sp.step) + " (halved at the first two reversals), within " + num(sp.min) + " to " + num(sp.max) +
            ", stopped at " + std::to_string(sp.reversals) + " reversals or " + std::to_string(sp.max_trials) +
            " trials. The threshold is the mean strength at the reversals after the first two. Its trials are "
            "not in the comparisons above.";
  Table t;
  t.header = {"Participant", "Baseline", "Baseline trials", "Trials", "Reversals", "Threshold", "Stopped"};
  for (const StaircaseRow& r : a.staircases) {
    if (!r.note.empty()) {
      t.rows.push_back({{r.participant}, {"N/A"}, {"0"}, {"0"}, {"0"}, {"N/A"}, {r.note}});
      continue;
    }
    t.rows.push_back({{r.participant}, {num(r.baseline)}, {std::to_string(r.baseline_trials)},
                      {std::to_string(r.trials.size())}, {std::to_string(r.reversals.size())},
                      {r.threshold ? num(*r.threshold) : "none", r.threshold.has_value()},
                      {r.finished ? r.stop_reason : "not finished"}});
  }
  t.note = "Baseline in the measure's unit; threshold in the field's.";
  s.tables.push_back(std::move(t));
  return s;
}

// A merged multi-site study: who ran where, and whether the sites are
// confounded with the settings (site_balance.h; docs/analysis.md).
Section sites_section(const StudyAnalysis& a) {
  Section s;
  s.title = "Sites";
  std::map<std::string, std::vector<std::string>> by_site;
  for (const std::string& p : a.participants)
    if (const auto it = a.participant_sites.find(p); it != a.participant_sites.end()) by_site[it->second].push_back(p);
  s.intro = "A study merged from " + std::to_string(by_site.size()) +
            " site file(s) (hapticlab study merge). A setting run at one site only is confounded with that site; "
            "the site x setting table is balanced when every site ran every setting with the same share of its "
            "participants (docs/analysis.md, \"Multi-site studies\").";
  Table who;
  who.header = {"Site", "Participants"};
  for (const auto& [site, people] : by_site) {
    std::string list;
    for (const std::string& p : people) list += (list.empty() ? "" : ", ") + p;
    who.rows.push_back({{site}, {list}});
  }
  s.tables.push_back(std::move(who));
  for (const SiteBalance& b : a.site_balance) {
    Table t;
    t.title = b.task + ": participants per site and setting";
    t.header = {"Site (participants)"};
    for (const std::string& setting : b.settings) t.header.push_back(setting);
    for (std::size_t i = 0; i < b.sites.size(); ++i) {
      std::vector<Cell> row = {{b.sites[i] + " (" + std::to_string(b.participants[i]) + ")"}};
      for (std::size_t j = 0; j < b.settings.size(); ++j) {
        bool flagged = std::find(b.unbalanced.begin(), b.unbalanced.end(), b.settings[j]) != b.unbalanced.end();
        for (const auto& c : b.confounded) flagged = flagged || c.first == b.settings[j];
        row.push_back({std::to_string(b.counts[i][j]), flagged});
      }
      t.rows.push_back(std::move(row));
    }
    t.note = (b.balanced() ? "" : "Bold: the settings concerned. ") + std::string("Sites are ") + b.verdict() + ".";
    s.tables.push_back(std::move(t));
  }
  if (a.site_balance.empty())
    s.intro += " No task has analysed trials at two or more sites, so nothing can be confounded.";
  return s;
}

Section energy_section(const StudyAnalysis& a) {
  // Bold above this net: more than a passive VE and engine hand back at the
  // end of a trial. What they hold then is small: the demo's High Fidelity
  // and Cogging trials end within ±3 mJ; float32 storage adds ~1e-10 J; an
  // instability gives hundreds of mJ (docs/analysis.md, "Energy").
  constexpr double kGeneratedThreshold_mJ = 5.0;
  Section s;
  s.title = "Energy the device exchanged with the hands";
  s.intro = "Per trial and hand, over the whole trial: the work of the commanded force on the hand (force times "
            "the joints' motion, the three joint axes summed). 'Gave' sums the updates where the device pushed "
            "along the motion, 'took' those where it resisted; net = gave - took. A passive VE and engine take at "
            "least what they give, up to what they hold when the trial ends; friction and tissue damping make the "
            "net negative. 'Engine, net' is the engine's part: the command minus the VE's own force (negative: "
            "the degradations dissipated; positive: they added energy, or a force clip removed the tissue's "
            "resistance). Per axis: metrics.csv.";
  Table t;
  t.header = {"Task",         "Setting",           "Hand", "Trials", "Gave (median, mJ)", "Took (median, mJ)",
              "Net (median, mJ)", "Net (largest, mJ)", "Engine, net (median, mJ)"};
  std::size_t generating = 0;
  for (const auto& task : a.tasks) {
    for (const auto& setting : a.settings) {
      for (int hand = 0; hand < 2; ++hand) {
        std::vector<double> gave, took, net, engine;
        for (const TrialRecord& tr : a.trials) {
          const auto& e = tr.energy[static_cast<std::size_t>(hand)];
          if (tr.task != task || tr.setting != setting || !e) continue;
          gave.push_back(e->device_out_J() * 1e3);
          took.push_back(e->device_in_J() * 1e3);
          net.push_back(e->device_net_J() * 1e3);
          engine.push_back(e->engine_net_J() * 1e3);
        }
        if (net.empty()) continue;
        const double largest = *std::max_element(net.begin(), net.end());
        const bool generated = largest > kGeneratedThreshold_mJ;
        if (generated) ++generating;
        t.rows.push_back({{task}, {setting}, {hand_name(hand)}, {std::to_string(net.size())},
                          {num(percentile(gave, 50.0))}, {num(percentile(took, 50.0))}, {num(percentile(net, 50.0))},
                          {num(largest), generated}, {num(percentile(engine, 50.0))}});
      }
    }
  }
  if (t.rows.empty()) {
    t.note = "No trial's device channels were read (a damaged chunk leaves a trial's energy out).";
  } else {
    t.note = "Bold: at least one trial in which the device gave the hand more than " + num(kGeneratedThreshold_mJ) +
             " mJ beyond what it took (" + std::to_string(generating) + " of " + std::to_string(t.rows.size()) +
             " rows).";
  }
  s.tables.push_back(std::move(t));
  return s;
}

Section ks_section(const StudyAnalysis& a) {
  Section s;
  s.title = "Appendix I: Kolmogorov-Smirnov with the moving block bootstrap";
  const auto& o = a.options;
  s.intro = "95% ranges of D between two " + a.control + " repetitions (D_intra) and between a " + a.control +
            " repetition and one of the other setting (D_inter), " + std::to_string(o.ks_resamples) +
            " resamples at every level (participant, repetition, moving blocks of " +
            std::to_string(o.ks_block_length) + " samples of the series kept at every " +
            std::to_string(o.ks_stride) + "th sample). Significant (bold) when the ranges do not overlap.";
  if (!o.ks) {
    s.intro = "Not computed (--no-ks).";
    return s;
  }
  Table t;
  t.header = {"Task", "Hand", "Quantity", "Setting", "Participants", "D_intra 95%", "D_inter 95%", "Significant",
              "Note"};
  for (const auto& r : a.ks) {
    if (r.result) {
      const auto& x = *r.result;
      t.rows.push_back({{r.task}, {hand_name(r.hand)}, {r.quantity}, {r.setting}, {std::to_string(x.participants_used)},
                        {num(x.intra.low, "%.3f") + " - " + num(x.intra.high, "%.3f")},
                        {num(x.inter.low, "%.3f") + " - " + num(x.inter.high, "%.3f")},
                        {x.significant ? "yes" : "no", x.significant}, {r.note}});
    } else {
      t.rows.push_back({{r.task}, {hand_name(r.hand)}, {r.quantity}, {r.setting}, {"0"}, {"N/A"}, {"N/A"}, {""},
                        {r.note}});
    }
  }
  s.tables.push_back(std::move(t));
  return s;
}

}  // namespace hapticlab::analysis::report_parts
