#include "analysis/study/headline_format.h"

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

#include "analysis/study/ordered_names.h"

namespace hapticlab::analysis {

std::string setting_abbreviation(const std::string& name) {
  std::istringstream words(name);
  std::vector<std::string> parts;
  for (std::string w; words >> w;) parts.push_back(w);
  if (parts.size() < 2) return name;
  std::string out;
  for (const auto& w : parts) {
    // A number and "=" stay whole: a dose series' settings ("Insertion
    // friction, dynamic_level_N = 0.45") differ only there.
    char* end = nullptr;
    std::strtod(w.c_str(), &end);
    const bool number = end == w.c_str() + w.size();
    if (number || w == "=" || w == "+")
      out += w;
    else
      out += static_cast<char>(std::toupper(static_cast<unsigned char>(w[0])));
  }
  return out;
}

std::string format_p(double p) {
  if (!std::isfinite(p)) return "N/A";
  if (p == 0.0) return "0";
  char buf[32];
  if (p >= 1e-3) {
    std::snprintf(buf, sizeof buf, "%.2g", p);
    return buf;
  }
  // The thesis' style for small p: one digit and a power of ten, "6E-5".
  int exponent = static_cast<int>(std::floor(std::log10(p)));
  double mantissa = std::round(p / std::pow(10.0, exponent));
  if (mantissa >= 10.0) {
    mantissa = 1.0;
    ++exponent;
  }
  std::snprintf(buf, sizeof buf, "%.0fE%d", mantissa, exponent);
  return buf;
}

std::string thesis_pairwise_table(const std::string& task) {
  if (task == "dissection") return "Table 3.5";
  if (task == "clip") return "Table 3.6";
  return "Table (" + task + ")";
}

std::string format_level(double level) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", level);
  return buf;
}

std::string format_p(double p, double level) {
  std::string text = format_p(p);
  if (!std::isfinite(p) || !std::isfinite(level) || p == 0.0) return text;
  const double shown_level = std::strtod(format_level(level).c_str(), nullptr);
  // Trailing zeros kept ("0.007300"), so the digits shown say how close it is.
  const auto rounded = [](double v, int digits) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%#.*g", digits, v);
    return std::string(buf);
  };
  // Readable: on the same side of the level as printed as p is of the level,
  // and not the same text as the level at this precision (0.00729 against
  // 0.0073 must not print as "0.0073").
  const auto readable = [&](const std::string& shown, int digits) {
    const bool below = std::strtod(shown.c_str(), nullptr) < shown_level;
    return below == (p < level) && (p == level || rounded(p, digits) != rounded(level, digits));
  };
  if (readable(text, 2)) return text;
  for (int digits = 3; digits < 17; ++digits) {
    text = rounded(p, digits);
    if (readable(text, digits)) return text;
  }
  return rounded(p, 17);
}

// ---------------------------------------------------------------------------
// Headline tables
// ---------------------------------------------------------------------------
namespace {

std::string pad(const std::string& s, std::size_t width) {
  // Width in characters, not bytes, so names with UTF-8 stay aligned.
  std::size_t chars = 0;
  for (unsigned char c : s) chars += (c & 0xC0) != 0x80;
  return s + std::string(width > chars ? width - chars : 1, ' ');
}

constexpr std::size_t kRowWidth = 26;
constexpr std::size_t kColWidth = 14;

// The control against each setting, one task: a heading row of measures,
// then a row per setting, "p**" where significant; `mark` may dress a cell
// (the thesis' gated comparisons go in parentheses).
template <typename Cell, typename Mark>
void comparison_rows(std::ostream& out, const StudyAnalysis& a, const std::string& task, const std::vector<Cell>& cells,
                     Mark mark) {
  out << pad("", kRowWidth);
  for (Measure m : kAllMeasures) out << pad(measure_label(m), kColWidth);
  out << "\n";
  for (std::size_t si = 1; si < a.settings.size(); ++si) {
    std::size_t participants = 0;
    for (const auto& cell : cells)
      if (cell.task == task && cell.setting == a.settings[si]) participants = std::max(participants, cell.participants);
    out << pad(a.settings[si] + " (" + std::to_string(participants) + ")", kRowWidth);
    for (Measure m : kAllMeasures) {
      std::string text = "N/A";
      for (const auto& cell : cells)
        if (cell.task == task && cell.setting == a.settings[si] && cell.measure == m && cell.p)
          text = mark(cell, format_p(*cell.p, a.sidak_level) + (cell.significant ? "**" : ""));
      out << pad(text, kColWidth);
    }
    out << "\n";
  }
}

// The heading row of measures above a table's rows.
void measure_heading(std::ostream& out) {
  out << pad("", kRowWidth);
  for (Measure m : kAllMeasures) out << pad(measure_label(m), kColWidth);
  out << "\n";
}

// Which trials were analysed and which left out, and the options.
void write_counts(std::ostream& out, const StudyAnalysis& a) {
  const TrialCounts& c = a.counts;
  out << "Study '" << a.study_name << "' (" << a.db_path.string() << ")\n";
  out << "Trials analysed: " << c.analysed << " (" << c.complete << " complete";
  if (c.aborted_included > 0) out << ", " << c.aborted_included << " aborted included";
  out << "); aborted left out: " << c.aborted_excluded << "; not run: " << c.not_run
      << "; without a task window: " << c.without_window;
  if (c.damaged_chunks > 0) out << " (" << c.damaged_chunks << " damaged sample chunk(s) left out)";
  out << "\n";
  out << "Percentiles: " << percentile_method_name(a.options.percentile_method) << "; alpha = " << a.options.alpha
      << "; control: " << a.control << "\n\n";
}

// Table 3.4: Friedman across settings, one row per task and participant.
void write_friedman_table(std::ostream& out, const StudyAnalysis& a) {
  out << "Table 3.4  Friedman across settings per participant (hands as blocks, repetitions as replicates): p\n";
  measure_heading(out);
  for (const auto& task : a.tasks) {
    for (const auto& participant : a.participants) {
      std::vector<const FriedmanRow*> rows;
      for (const auto& r : a.friedman)
        if (r.task == task && r.participant == participant && r.hand == -1) rows.push_back(&r);
      if (rows.empty()) continue;
      out << pad(task + " " + participant, kRowWidth);
      for (Measure m : kAllMeasures) {
        std::string cell = "N/A";
        for (const auto* r : rows) {
          if (r->measure == m && r->test.result) {
            cell = format_p(r->test.result->p, a.options.alpha) + (r->test.result->p < a.options.alpha ? "*" : "");
          }
        }
        out << pad(cell, kColWidth);
      }
      out << "\n";
    }
  }
  out << "* p < " << a.options.alpha << "\n\n";
}

// Each setting against the control: one value per participant (the
// default) and the thesis' procedure, the chosen method first.
void write_comparison_tables(std::ostream& out, const StudyAnalysis& a) {
  const std::string level = format_level(a.sidak_level);
  std::ostringstream thesis;
  for (const auto& task : a.tasks) {
    thesis << thesis_pairwise_table(task) << "  " << task << ": " << a.control
           << " compared to (participants), the thesis' procedure (repetitions and hands as replicates): p, "
              "significant below the Šidák level "
           << level << " (m = " << a.sidak_m << ")\n";
    comparison_rows(thesis, a, task, a.pairwise, [](const PairwiseCell& c, std::string text) {
      return c.gated ? "(" + text + ")" : text;
    });
    thesis << "** p < " << level << "; (p): no participant's Table 3.4 test was significant for this measure, "
           << "so the thesis' procedure would not compare\n\n";
  }
  std::ostringstream participant;
  for (const auto& task : a.tasks) {
    participant << task << ": " << a.control
                << " compared to (participants), one value per participant (median over repetitions and hands), "
                   "exact sign-flip test: p, significant below the Šidák level "
                << level << "\n";
    comparison_rows(participant, a, task, a.participant_pairwise,
                    [](const ParticipantPairwiseCell&, std::string text) { return text; });
    participant << "** p < " << level << "; with n participants the smallest p is 2/2^n (0.25 for 3, 0.0078 for 8)\n\n";
  }
  if (a.options.method == ComparisonMethod::kThesis)
    out << thesis.str() << participant.str();
  else
    out << participant.str() << thesis.str();
}

// All participants at once, one row per task.
void write_whole_design_table(std::ostream& out, const StudyAnalysis& a) {
  out << "All participants at once (per-cell medians; Friedman if complete, else Durbin or Skillings-Mack): p\n";
  measure_heading(out);
  for (const auto& task : a.tasks) {
    out << pad(task, kRowWidth);
    for (Measure m : kAllMeasures) {
      std::string text = "N/A";
      for (const auto& r : a.whole_design) {
        if (r.task == task && r.measure == m && r.test.result) {
          text = format_p(r.test.result->p, a.options.alpha) + (r.test.result->p < a.options.alpha ? "*" : "");
          text += " " + std::string(r.test.result->method == "Skillings-Mack" ? "SM" : r.test.result->method.substr(0, 1));
        }
      }
      out << pad(text, kColWidth);
    }
    out << "\n";
  }
  out << "F Friedman, D Durbin, SM Skillings-Mack; * p < " << a.options.alpha << "\n";
}

// A dose series' trend and smallest significant strength, per task.
void write_dose_table(std::ostream& out, const StudyAnalysis& a) {
  out << "\nDose-response of " << a.dose->field << " (each participant's slope over strengths, exact sign-flip "
      << "test; the smallest significant strength by the fixed sequence from the strongest, alpha "
      << a.options.alpha << ")\n";
  measure_heading(out);
  for (const auto& task : a.tasks) {
    std::string trend_line = pad(task + " trend p", kRowWidth);
    std::string smallest_line = pad(task + " smallest", kRowWidth);
    for (Measure m : kAllMeasures) {
      std::string trend = "N/A";
      std::string smallest = "none";
      for (const DoseResponseRow& r : a.dose_response) {
        if (r.task != task || r.measure != m) continue;
        if (r.trend_p)
          trend = format_p(*r.trend_p, a.options.alpha) + (r.trend_significant ? "*" : "") +
                  (r.mean_slope > 0 ? " up" : r.mean_slope < 0 ? " down" : "");
        if (r.smallest_significant_strength) smallest = format_level(*r.smallest_significant_strength);
      }
      trend_line += pad(trend, kColWidth);
      smallest_line += pad(smallest, kColWidth);
    }
    out << trend_line << "\n" << smallest_line << "\n";
  }
  out << "* p < " << a.options.alpha << "; up/down: the mean slope's sign; smallest: the smallest strength with a "
      << "significant change from " << a.control << "\n";
}

// An adaptive staircase's threshold, per participant.
void write_staircase_table(std::ostream& out, const StudyAnalysis& a) {
  out << "\nAdaptive staircase of " << a.staircase->field << " (" << a.staircase->measure << " changed by "
      << 100.0 * a.staircase->change << " % from " << a.staircase->baseline << "; " << a.counts.staircase
      << " staircase trials, not in the comparisons above)\n";
  for (const StaircaseRow& r : a.staircases) {
    out << pad(r.participant, kRowWidth);
    if (!r.note.empty()) {
      out << r.note << "\n";
      continue;
    }
    out << (r.threshold ? "threshold " + format_level(*r.threshold) : std::string("no threshold")) << " after "
        << r.trials.size() << " trials, " << r.reversals.size() << " reversals"
        << (r.finished ? " (" + r.stop_reason + ")" : std::string(" (not finished)")) << "\n";
  }
}

}  // namespace

std::string format_headline_tables(const StudyAnalysis& a) {
  std::ostringstream out;
  write_counts(out, a);
  write_friedman_table(out, a);
  write_comparison_tables(out, a);
  write_whole_design_table(out, a);
  if (a.dose) write_dose_table(out, a);
  if (a.staircase) write_staircase_table(out, a);
  return out.str();
}

}  // namespace hapticlab::analysis
