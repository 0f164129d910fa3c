#include "analysis/study/headline_format.h"
#include "analysis/report/report.h"

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

namespace hapticlab::analysis {
namespace {

// ---------------------------------------------------------------------------
// Document model: sections of tables and figures, rendered twice.
// ---------------------------------------------------------------------------
struct Cell {
  std::string text;
  bool bold = false;
};

struct Table {
  std::string title;
  std::vector<std::string> header;
  std::vector<std::vector<Cell>> rows;
  std::string note;
};

struct Figure {
  std::string file;  // relative to the report, "figures/x.svg"
  std::string caption;
};

struct Section {
  std::string title;
  std::string intro;
  std::vector<Table> tables;
  std::vector<Figure> figures;
};

std::string num(double v, const char* format = "%.3g") {
  if (!std::isfinite(v)) return "N/A";
  char buf[48];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

// File-name-safe form of a participant code or task name.
std::string slug(const std::string& s) {
  std::string out;
  for (char c : s) out += std::isalnum(static_cast<unsigned char>(c)) || c == '-' ? c : '_';
  return out.empty() ? "_" : out;
}

std::string html_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string md_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '|' || c == '*' || c == '_') out += '\\';
    out += c;
  }
  return out;
}

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw DataError("cannot read '" + path.string() + "'");
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_file(const std::filesystem::path& path, const std::string& text) {
  try {
    write_file_atomically(path, text);
  } catch (const OutputFileError& e) {
    throw DataError(std::string("cannot write the report: ") + e.what());
  }
}

std::string render_html(const std::string& title, const std::vector<Section>& sections,
                        const std::filesystem::path& dir) {
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>" << html_escape(title)
    << "</title>\n<style>\n"
       "body{font-family:Helvetica,Arial,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}\n"
       "table{border-collapse:collapse;margin:0.5em 0 0.3em}th,td{border:1px solid #bbb;padding:3px 8px;"
       "text-align:left}th{background:#eee}td.b{font-weight:bold}\n"
       "p.note{font-size:0.9em;color:#555;margin-top:0}figure{display:block;margin:1em 0}"
       "figcaption{font-size:0.9em;color:#444}\n"
       "summary{cursor:pointer;font-weight:bold}\n"
       // Figures span the text column, as in a journal; the SVG scales (its viewBox keeps the proportions).
       "figure svg{display:block;width:100%;height:auto}\n</style></head><body>\n";
  h << "<h1>" << html_escape(title) << "</h1>\n";
  h << "<nav><h2 id=\"contents\">Contents</h2><ol>\n";
  for (std::size_t i = 0; i < sections.size(); ++i)
    h << "<li><a href=\"#section-" << i + 1 << "\">" << html_escape(sections[i].title) << "</a></li>\n";
  h << "</ol></nav>\n";
  int figure_number = 0;
  std::size_t section_number = 0;
  for (const Section& s : sections) {
    h << "<h2 id=\"section-" << ++section_number << "\">" << html_escape(s.title) << "</h2>\n";
    if (!s.intro.empty()) h << "<p>" << html_escape(s.intro) << "</p>\n";
    for (const Table& t : s.tables) {
      if (!t.title.empty()) h << "<h3>" << html_escape(t.title) << "</h3>\n";
      h << "<table><tr>";
      for (const auto& c : t.header) h << "<th>" << html_escape(c) << "</th>";
      h << "</tr>\n";
      for (const auto& row : t.rows) {
        h << "<tr>";
        for (const auto& c : row) h << (c.bold ? "<td class=\"b\">" : "<td>") << html_escape(c.text) << "</td>";
        h << "</tr>\n";
      }
      h << "</table>\n";
      if (!t.note.empty()) h << "<p class=\"note\">" << html_escape(t.note) << "</p>\n";
    }
    // Figures of one kind fold away together: a study gives dozens.
    if (!s.figures.empty())
      h << "<details><summary>" << s.figures.size() << (s.figures.size() == 1 ? " figure" : " figures")
        << "</summary>\n";
    for (const Figure& f : s.figures) {
      ++figure_number;
      h << "<figure>" << inline_svg(read_file(dir / f.file), "fig" + std::to_string(figure_number) + "_") << "<figcaption>" << html_escape(f.caption)
        << "</figcaption></figure>\n";
    }
    if (!s.figures.empty()) h << "</details>\n";
  }
  h << "</body></html>\n";
  return h.str();
}

std::string render_markdown(const std::string& title, const std::vector<Section>& sections) {
  std::ostringstream m;
  m << "# " << title << "\n\n";
  for (const Section& s : sections) {
    m << "## " << s.title << "\n\n";
    if (!s.intro.empty()) m << s.intro << "\n\n";
    for (const Table& t : s.tables) {
      if (!t.title.empty()) m << "### " << t.title << "\n\n";
      m << "|";
      for (const auto& c : t.header) m << " " << md_escape(c) << " |";
      m << "\n|";
      for (std::size_t i = 0; i < t.header.size(); ++i) m << "---|";
      m << "\n";
      for (const auto& row : t.rows) {
        m << "|";
        for (const auto& c : row) m << " " << (c.bold ? "**" + md_escape(c.text) + "**" : md_escape(c.text)) << " |";
        m << "\n";
      }
      m << "\n";
      if (!t.note.empty()) m << "*" << t.note << "*\n\n";
    }
    for (const Figure& f : s.figures) m << "![" << f.caption << "](" << f.file << ")\n\n*" << f.caption << "*\n\n";
  }
  return m.str();
}

// ---------------------------------------------------------------------------
// Tables
// ---------------------------------------------------------------------------
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

// ---------------------------------------------------------------------------
// Figures
// ---------------------------------------------------------------------------
class FigureBuilder {
 public:
  FigureBuilder(const StudyAnalysis& a, const ReportOptions& o) : a_(a), o_(o) { script_.set_pdf(o.pdf); }

  GnuplotScript& script() { return script_; }

  // Figures 3-4 / 3-5: CDFs of |F| and |v| per participant, hand and setting;
  // repetitions weigh equally (the thesis resampled each to the same count).
  Section cdfs(bool force) {
    Section s;
    s.title = force ? "Figure 3-4: CDFs of tool-tip force" : "Figure 3-5: CDFs of tool-tip speed";
    s.intro = std::string("Cumulative distribution of ") +
              (force ? "|F| (samples with |F| >= the contact threshold)" : "|v|") +
              " in the task window, the repetitions of a setting pooled with equal weight (speed on a log axis: it spans decades). Axes are the same "
              "within a task.";
    for (const auto& task : a_.tasks) {
      // Same x range on every plot of a task (as in the thesis): the largest 99th percentile.
      double x_max = 0.0;
      double x_min = std::numeric_limits<double>::infinity();
      std::vector<std::tuple<std::string, int, std::vector<std::pair<std::string, std::vector<double>>>>> plots;
      for (const auto& participant : a_.participants) {
        for (int hand = 0; hand < 2; ++hand) {
          std::vector<std::pair<std::string, std::vector<double>>> curves;
          for (const auto& setting : a_.settings) {
            std::vector<double> pooled;
            for (const auto& t : a_.trials) {
              if (t.task != task || t.participant != participant || t.setting != setting) continue;
              const auto& q = force ? t.force_quantiles_N[static_cast<std::size_t>(hand)]
                                    : t.speed_quantiles_m_per_s[static_cast<std::size_t>(hand)];
              pooled.insert(pooled.end(), q.begin(), q.end());
            }
            if (pooled.empty()) continue;
            std::sort(pooled.begin(), pooled.end());
            x_max = std::max(x_max, percentile_sorted(pooled, 99.0, a_.options.percentile_method));
            // Speeds spread over decades (a hand at rest and one moving): a
            // log axis from the smallest 1st percentile that is above zero.
            for (double v : pooled)
              if (v > 0.0 && v >= percentile_sorted(pooled, 1.0, a_.options.percentile_method)) {
                x_min = std::min(x_min, v);
                break;
              }
            curves.emplace_back(setting, std::move(pooled));
          }
          if (!curves.empty()) plots.emplace_back(participant, hand, std::move(curves));
        }
      }
      for (auto& [participant, hand, curves] : plots) {
        std::ostringstream data;
        std::ostringstream plot;
        plot << "plot ";
        for (std::size_t c = 0; c < curves.size(); ++c) {
          const auto& pooled = curves[c].second;
          const std::size_t points = std::max<std::size_t>(o_.cdf_curve_points, 2);
          for (std::size_t i = 0; i < points; ++i) {
            const double p = static_cast<double>(i) / static_cast<double>(points - 1);
            const double x = percentile_sorted(pooled, 100.0 * p, a_.options.percentile_method);
            if (!force && x <= 0.0) continue;  // not on a log axis
            data << x << ' ' << p << '\n';
          }
          data << "\n\n";
          plot << (c ? ", " : "") << "$" << block_name() << " index " << c << " with lines lw 2 title "
               << gnuplot_quote(setting_abbreviation(curves[c].first));
        }
        const std::string name = block_name();
        script_.add_datablock(name, data.str());
        const std::string file = std::string("cdf_") + (force ? "force_" : "speed_") + slug(task) + "_" +
                                 slug(participant) + "_" + hand_name(hand) + ".svg";
        std::ostringstream cmd;
        cmd << "set title " << gnuplot_quote(task + ", " + participant + ", " + hand_name(hand) + " hand") << "\n"
            << "set xlabel " << gnuplot_quote(force ? "|F| [N]" : "|v| [m/s]") << "\n"
            << "set ylabel 'cumulative probability'\nset yrange [0:1]\n";
        if (force || !(x_min < x_max)) {
          cmd << "set xrange [0:" << (x_max > 0 ? x_max : 1) << "]\n";
        } else {
          // At most three decades: a hand held still (backlash can stop
          // the tool exactly) gives speeds down to 1e-35 m/s.
          cmd << "set logscale x\nset xrange [" << std::max(x_min, x_max * 1e-3) << ":" << x_max << "]\n";
        }
        cmd << (force ? "set key right bottom\n" : "set key left top\n") << "set grid\n"
            << plot.str() << "\n";
        add(s, file, cmd.str(),
            std::string(force ? "Force" : "Speed") + " CDF: " + task + ", " + participant + ", " + hand_name(hand) +
                " hand.");
        ++block_;
      }
    }
    return s;
  }

  // Figures 3-6 to 3-10: each repetition's value, grouped by participant and setting.
  Section repetitions() {
    Section s;
    s.title = "Figures 3-6 to 3-10: values per repetition";
    s.intro = "Each point is one repetition; groups are participants, colours settings.";
    for (const auto& task : a_.tasks) {
      for (Measure m : kAllMeasures) {
        for (int hand = measure_per_hand(m) ? 0 : -1; hand < (measure_per_hand(m) ? 2 : 0); ++hand) {
          std::vector<std::string> group_names;
          std::ostringstream data;
          std::ostringstream plot;
          plot << "plot ";
          const double width = static_cast<double>(a_.settings.size() + 1);
          for (const auto& participant : a_.participants) {
            const bool did = std::any_of(a_.trials.begin(), a_.trials.end(), [&](const TrialRecord& t) {
              return t.task == task && t.participant == participant;
            });
            if (did) group_names.push_back(participant);
          }
          std::size_t datasets = 0;
          for (std::size_t si = 0; si < a_.settings.size(); ++si) {
            std::size_t rows = 0;
            for (std::size_t g = 0; g < group_names.size(); ++g) {
              for (const auto& t : a_.trials) {
                if (t.task != task || t.participant != group_names[g] || t.setting != a_.settings[si]) continue;
                const double v = t.value(m, std::max(hand, 0));
                if (!std::isfinite(v)) continue;
                data << static_cast<double>(g) * width + static_cast<double>(si) + 1.0 << ' ' << v << '\n';
                ++rows;
              }
            }
            if (rows == 0) continue;
            data << "\n\n";
            plot << (datasets ? ", " : "") << "$" << block_name() << " index " << datasets
                 << " with points pt 7 ps 0.7 title " << gnuplot_quote(setting_abbreviation(a_.settings[si]));
            ++datasets;
          }
          if (datasets == 0) continue;
          std::ostringstream tics;
          for (std::size_t g = 0; g < group_names.size(); ++g) {
            tics << (g ? ", " : "") << gnuplot_quote(group_names[g]) << " "
                 << static_cast<double>(g) * width + width / 2.0;
          }
          script_.add_datablock(block_name(), data.str());
          const std::string hand_text = hand < 0 ? "" : std::string(", ") + hand_name(hand) + " hand";
          std::ostringstream cmd;
          cmd << "set title " << gnuplot_quote(task + ": " + measure_label(m) + hand_text) << "\n"
              << "set ylabel " << gnuplot_quote(std::string(measure_label(m)) + " [" + measure_unit(m) + "]") << "\n"
              << "set xtics (" << tics.str() << ")\nset xrange [0:" << static_cast<double>(group_names.size()) * width
              << "]\nset key outside right\nset grid y\n"
              << plot.str() << "\n";
          add(s, std::string("reps_") + measure_column(m) + "_" + slug(task) + (hand < 0 ? "" : std::string("_") + hand_name(hand)) + ".svg",
              cmd.str(), std::string(measure_label(m)) + " per repetition, " + task + hand_text + ".");
          ++block_;
        }
      }
    }
    return s;
  }

  // Figures 3-11 to 3-13: box plots, whiskers to 3 × IQR.
  Section boxes() {
    Section s;
    s.title = "Figures 3-11 to 3-13: box plots";
    s.intro = "Boxes span the 25th to 75th percentile around the median; whiskers reach the most extreme values "
              "within 3 x IQR of the box; '+' marks values beyond.";
    for (Measure m : {Measure::kForceMedian, Measure::kForceP95}) {
      std::vector<std::pair<std::string, std::vector<double>>> groups;
      for (const auto& task : a_.tasks) {
        for (int hand = 0; hand < 2; ++hand) {
          std::vector<double> v;
          for (const auto& t : a_.trials)
            if (t.task == task && std::isfinite(t.value(m, hand))) v.push_back(t.value(m, hand));
          if (!v.empty()) groups.emplace_back(task + "\n" + hand_name(hand), std::move(v));
        }
      }
      box_plot(s, groups, m, std::string("box_") + measure_column(m) + "_hands.svg",
               std::string(measure_label(m)) + ": left versus right hand, all participants and settings.");
    }
    std::vector<std::pair<std::string, std::vector<double>>> groups;
    for (const auto& task : a_.tasks) {
      for (const auto& participant : a_.participants) {
        std::vector<double> v;
        for (const auto& t : a_.trials) {
          const double x = t.value(Measure::kCompletionTime, 0);
          if (t.task == task && t.participant == participant && std::isfinite(x)) v.push_back(x);
        }
        if (!v.empty()) groups.emplace_back(task + "\n" + participant, std::move(v));
      }
    }
    box_plot(s, groups, Measure::kCompletionTime, "box_completion_time_participants.svg",
             "Completion times compared between participants, all settings.");
    return s;
  }

  // Figures 3-15 to 3-17: measure against trial number, with the least-squares line.
  Section correlations() {
    Section s;
    // Titled by what it shows: the thesis' Figures 3-15 to 3-17 were three
    // such plots, a study may give any number.
    std::vector<const CorrelationRow*> rows;
    for (const auto& r : a_.correlations)
      if (r.result && std::abs(r.result->r) >= o_.correlation_plot_min_abs_r) rows.push_back(&r);
    std::stable_sort(rows.begin(), rows.end(), [](const CorrelationRow* x, const CorrelationRow* y) {
      return std::abs(x->result->r) > std::abs(y->result->r);
    });
    const std::size_t shown = std::min(rows.size(), o_.max_correlation_plots);
    s.title = std::string(shown == 1 ? "Measure" : "Measures") + " against trial number (" + count_of(shown, "figure") +
              ", like the thesis' Figures 3-15 to 3-17)";
    s.intro = "Correlations with |r| >= " + num(o_.correlation_plot_min_abs_r) + " (the thesis' reporting threshold): " +
              std::to_string(rows.size()) + (shown < rows.size() ? ", the strongest " + std::to_string(shown) + " shown" : "") +
              ". The line is the least-squares trend; markers show the setting.";
    for (std::size_t i = 0; i < shown; ++i) {
      const CorrelationRow& r = *rows[i];
      std::ostringstream data;
      std::ostringstream plot;
      plot << "plot ";
      std::size_t datasets = 0;
      for (const auto& setting : a_.settings) {
        std::size_t n = 0;
        for (std::size_t k = 0; k < r.values.size(); ++k) {
          if (r.settings[k] != setting) continue;
          data << r.trial_numbers[k] << ' ' << r.values[k] << '\n';
          ++n;
        }
        if (n == 0) continue;
        data << "\n\n";
        plot << (datasets ? ", " : "") << "$" << block_name() << " index " << datasets << " with points pt "
             << (datasets % 6 + 4) << " ps 1 title " << gnuplot_quote(setting_abbreviation(setting));
        ++datasets;
      }
      // Least-squares line through the points: slope Sxy/Sxx.
      const double nx = static_cast<double>(r.values.size());
      double mx = 0, my = 0;
      for (std::size_t k = 0; k < r.values.size(); ++k) {
        mx += r.trial_numbers[k] / nx;
        my += r.values[k] / nx;
      }
      double sxy = 0, sxx = 0;
      for (std::size_t k = 0; k < r.values.size(); ++k) {
        sxy += (r.trial_numbers[k] - mx) * (r.values[k] - my);
        sxx += (r.trial_numbers[k] - mx) * (r.trial_numbers[k] - mx);
      }
      const double slope = sxx > 0 ? sxy / sxx : 0.0;
      const auto [lo, hi] = std::minmax_element(r.trial_numbers.begin(), r.trial_numbers.end());
      data << *lo << ' ' << my + slope * (*lo - mx) << '\n' << *hi << ' ' << my + slope * (*hi - mx) << '\n';
      plot << ", $" << block_name() << " index " << datasets << " with lines lw 2 lc rgb 'black' title 'trend'";
      script_.add_datablock(block_name(), data.str());
      const std::string what = std::string(measure_label(r.measure)) + " vs trial number: " + r.participant + ", " +
                               r.task + ", " + correlation_hand(r) + " hand";
      std::ostringstream cmd;
      cmd << "set title " << gnuplot_quote(what + "\n(R = " + num(r.result->r, "%.2f") + ", P = " + format_p(r.result->p, a_.options.alpha) + ")")
          << "\nset xlabel 'trial number'\nset ylabel "
          << gnuplot_quote(std::string(measure_label(r.measure)) + " [" + measure_unit(r.measure) + "]")
          << "\nset key outside right\nset grid\n"
          << plot.str() << "\n";
      add(s, "corr_" + std::to_string(i + 1) + ".svg", cmd.str(), what + ".");
      ++block_;
    }
    return s;
  }

  // Appendix I figures: the 95% ranges of D_intra (black) and D_inter (red).
  Section ks() {
    Section s;
    s.title = "Appendix I figures: KS intervals";
    s.intro = "Per row, black: 95% range of D within the control setting; red: between the control and the "
              "setting named. Non-overlapping ranges indicate a difference.";
    for (const auto& task : a_.tasks) {
      for (const char* quantity : {"force", "speed"}) {
        std::ostringstream data;
        std::ostringstream tics;
        std::size_t row = 0;
        for (const auto& r : a_.ks) {
          if (r.task != task || r.quantity != quantity || !r.result) continue;
          const auto& x = *r.result;
          data << x.intra.low << ' ' << x.intra.high << ' ' << x.inter.low << ' ' << x.inter.high << ' ' << row << '\n';
          tics << (row ? ", " : "") << gnuplot_quote(std::string(hand_name(r.hand)) + " " + setting_abbreviation(r.setting))
               << ' ' << row;
          ++row;
        }
        if (row == 0) continue;
        script_.add_datablock(block_name(), data.str());
        std::ostringstream cmd;
        cmd << "set title " << gnuplot_quote(task + ": KS D, " + quantity) << "\nset xlabel 'D'\nset xrange [0:1]\n"
            << "set yrange [-1:" << row << "]\nset ytics (" << tics.str() << ")\nset key below horizontal\nset grid x\n"
            << "plot $" << block_name() << " using 1:($5+0.15):($2-$1):(0) with vectors nohead lw 3 lc rgb 'black' "
            << "title 'D intra (control)', $" << block_name()
            << " using 3:($5-0.15):($4-$3):(0) with vectors nohead lw 3 lc rgb 'red' title 'D inter'\n";
        add(s, "ks_" + std::string(quantity) + "_" + slug(task) + ".svg", cmd.str(),
            "KS 95% ranges, " + std::string(quantity) + ", " + task + ".", 640,
            std::max(260, 90 + 22 * static_cast<int>(row)));
        ++block_;
      }
    }
    return s;
  }

  // Each participant's staircase track: the strength of every trial,
  // filled where the measure changed; the threshold dashed.
  Section staircase_tracks() {
    Section s;
    s.title = "Staircase tracks";
    s.intro = "The strength of each staircase trial; filled: the measure changed by the criterion, open: it did "
              "not. Dashed: the threshold.";
    for (const StaircaseRow& r : a_.staircases) {
      if (r.trials.empty()) continue;
      std::ostringstream changed, unchanged;
      for (std::size_t i = 0; i < r.trials.size(); ++i)
        (r.trials[i].changed ? changed : unchanged) << i + 1 << ' ' << r.trials[i].strength << '\n';
      // gnuplot cannot plot an empty datablock: a point outside the range stands in.
      if (changed.str().empty()) changed << "-1 0\n";
      if (unchanged.str().empty()) unchanged << "-1 0\n";
      std::ostringstream track;
      for (std::size_t i = 0; i < r.trials.size(); ++i) track << i + 1 << ' ' << r.trials[i].strength << '\n';
      const std::string b = block_name();
      script_.add_datablock(b, track.str() + "\n\n" + changed.str() + "\n\n" + unchanged.str());
      ++block_;
      std::ostringstream cmd;
      cmd << "set title " << gnuplot_quote("Staircase, " + r.participant) << "\nset xlabel 'staircase trial'\n"
          << "set ylabel " << gnuplot_quote(a_.staircase->field) << " noenhanced\nset grid\nset key outside bottom center horizontal\n"
          << "set xrange [0.5:" << r.trials.size() + 0.5 << "]\n";
      if (r.threshold)
        cmd << "set arrow from graph 0, first " << *r.threshold << " to graph 1, first " << *r.threshold
            << " nohead dt 2 lc rgb 'red'\n";
      cmd << "plot $" << b << " index 0 with lines lc rgb '#808080' notitle, $" << b
          << " index 1 with points pt 7 ps 1.2 lc rgb 'black' title 'changed', $" << b
          << " index 2 with points pt 6 ps 1.2 lc rgb 'black' title 'not changed'\n";
      add(s, "staircase_" + slug(r.participant) + ".svg", cmd.str(), "Staircase track: " + r.participant + ".");
    }
    return s;
  }

  // The dose-response curves: each participant's medians (thin) and their
  // median (thick) against the strength; the smallest significant strength dashed.
  Section dose_response() {
    Section s;
    s.title = "Dose-response curves";
    const DoseSeries& dose = *a_.dose;
    s.intro = "Each thin line is one participant's median per strength of " + dose.field +
              "; the thick line is the median over participants. A dashed line marks the smallest significant "
              "strength, where there is one.";
    for (const DoseResponseRow& r : a_.dose_response) {
      std::ostringstream data;
      std::size_t series = 0;
      for (const DoseParticipantFit& p : r.participants) {
        for (std::size_t i = 0; i < p.medians.size(); ++i)
          if (std::isfinite(p.medians[i])) data << dose.levels[i].strength << ' ' << p.medians[i] << '\n';
        data << "\n\n";
        ++series;
      }
      for (std::size_t i = 0; i < r.level_medians.size(); ++i)
        if (std::isfinite(r.level_medians[i])) data << dose.levels[i].strength << ' ' << r.level_medians[i] << '\n';
      if (series == 0) continue;
      const std::string b = block_name();
      script_.add_datablock(b, data.str());
      ++block_;
      std::ostringstream cmd;
      cmd << "set title " << gnuplot_quote(r.task + ": " + measure_label(r.measure)) << "\nset xlabel "
          << gnuplot_quote(dose.field) << " noenhanced\nset ylabel "
          << gnuplot_quote(std::string(measure_label(r.measure)) + " [" + measure_unit(r.measure) + "]")
          << "\nset grid\nset key left top\n";
      if (r.smallest_significant_strength)
        cmd << "set arrow from first " << *r.smallest_significant_strength << ", graph 0 to first "
            << *r.smallest_significant_strength << ", graph 1 nohead dt 2 lc rgb 'red'\n";
      cmd << "plot $" << b << " index 0:" << series - 1
          << " with linespoints lw 1 pt 7 ps 0.5 lc rgb '#a0a0a0' notitle, $" << b << " index " << series
          << " with linespoints lw 3 pt 7 lc rgb 'black' title 'median over participants'\n";
      add(s, "dose_" + slug(r.task) + "_" + measure_column(r.measure) + ".svg", cmd.str(),
          "Dose-response: " + r.task + ", " + measure_label(r.measure) + ".");
    }
    return s;
  }

 private:
  std::string block_name() const { return "d" + std::to_string(block_); }

  void add(Section& s, const std::string& file, const std::string& commands, const std::string& caption,
           int width = 640, int height = 420) {
    script_.add_plot(file, commands, width, height);
    s.figures.push_back({"figures/" + file, caption});
  }

  void box_plot(Section& s, const std::vector<std::pair<std::string, std::vector<double>>>& groups, Measure m,
                const std::string& file, const std::string& caption) {
    const std::string title = caption.substr(0, caption.find(':'));
    if (groups.empty()) return;
    std::ostringstream boxes;
    std::ostringstream outliers;
    std::ostringstream tics;
    for (std::size_t g = 0; g < groups.size(); ++g) {
      const BoxStats b = box_stats(groups[g].second, 3.0, a_.options.percentile_method);
      const double x = static_cast<double>(g + 1);
      boxes << x << ' ' << b.q1 << ' ' << b.whisker_low << ' ' << b.whisker_high << ' ' << b.q3 << ' ' << b.median
            << '\n';
      for (double v : b.outliers) outliers << x << ' ' << v << '\n';
      tics << (g ? ", " : "") << gnuplot_quote(groups[g].first) << ' ' << x;
    }
    // gnuplot cannot plot an empty datablock: a point outside the range stands in.
    if (outliers.str().empty()) outliers << "-1 0\n";
    const std::string b = block_name();
    script_.add_datablock(b, boxes.str());
    ++block_;
    const std::string o = block_name();
    script_.add_datablock(o, outliers.str());
    ++block_;
    std::ostringstream cmd;
    cmd << "set title " << gnuplot_quote(title) << "\nset ylabel "
        << gnuplot_quote(std::string(measure_label(m)) + " [" + measure_unit(m) + "]") << "\nset xtics (" << tics.str()
        // Two-line tick labels ("P1\nleft") need room below the axis, or the SVG clips the second line.
        << ")\nset bmargin 5\nset xrange [0.3:" << static_cast<double>(groups.size()) + 0.7 << "]\nset boxwidth 0.5\nset grid y\n"
        << "plot $" << b << " using 1:2:3:4:5 with candlesticks whiskerbars 0.5 lc rgb 'black' fs empty notitle, $" << b
        << " using 1:6:6:6:6 with candlesticks lc rgb 'red' lw 2 notitle, $" << o
        << " using 1:2 with points pt 1 ps 1 lc rgb 'black' notitle\n";
    add(s, file, cmd.str(), caption, std::max(480, 90 * static_cast<int>(groups.size()) + 160), 440);
  }

  const StudyAnalysis& a_;
  const ReportOptions& o_;
  GnuplotScript script_;
  std::size_t block_ = 0;
};

}  // namespace

ReportFiles write_report(const StudyAnalysis& a, const std::filesystem::path& out_dir, const ReportOptions& options) {
  // Before writing anything: a missing gnuplot must not leave half a report.
  std::filesystem::path gnuplot;
  if (options.plots) gnuplot = find_gnuplot();
  std::error_code ec;
  std::filesystem::create_directories(out_dir / "figures", ec);
  if (ec) throw DataError("cannot create the report directory '" + (out_dir / "figures").string() + "': " + ec.message());

  std::vector<Section> sections;
  sections.push_back(summary_section(a));
  if (!a.participant_sites.empty()) sections.push_back(sites_section(a));
  // The chosen comparison method's tables come first (AnalysisOptions::method).
  const bool participant_first = a.options.method == ComparisonMethod::kParticipant;
  if (participant_first)
    for (const auto& task : a.tasks) sections.push_back(participant_section(a, task));
  sections.push_back(friedman_section(a));
  for (const auto& task : a.tasks) sections.push_back(pairwise_section(a, task));
  if (!participant_first)
    for (const auto& task : a.tasks) sections.push_back(participant_section(a, task));
  sections.push_back(whole_design_section(a));
  sections.push_back(correlation_section(a, options));
  sections.push_back(ks_section(a));
  sections.push_back(energy_section(a));
  if (a.dose)
    for (const auto& task : a.tasks) sections.push_back(dose_response_section(a, task));
  if (a.staircase) sections.push_back(staircase_section(a));

  ReportFiles files;
  if (options.plots) {
    FigureBuilder figures(a, options);
    sections.push_back(figures.cdfs(true));
    sections.push_back(figures.cdfs(false));
    sections.push_back(figures.repetitions());
    sections.push_back(figures.boxes());
    sections.push_back(figures.correlations());
    if (a.options.ks) sections.push_back(figures.ks());
    if (a.dose) sections.push_back(figures.dose_response());
    if (a.staircase) sections.push_back(figures.staircase_tracks());
    const std::string key = abbreviation_key(a.settings);
    for (auto& s : sections)
      if (!s.figures.empty() && !key.empty()) s.intro += (s.intro.empty() ? "" : " ") + key;
    run_gnuplot(figures.script(), out_dir / "figures", gnuplot, options.plot_jobs);
    for (const auto& s : sections)
      for (const auto& f : s.figures) files.figures.push_back(out_dir / f.file);
  }

  const std::string title = "HapticLab study report: " + a.study_name;
  files.html = out_dir / "report.html";
  files.markdown = out_dir / "report.md";
  write_file(files.html, render_html(title, sections, out_dir));
  write_file(files.markdown, render_markdown(title, sections));
  return files;
}

}  // namespace hapticlab::analysis
