// The report's figures (Figures 3-4 to 3-17, Appendix I), drawn by gnuplot.
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

namespace {

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
  std::string block_name() const { return 'd' + std::to_string(block_); }

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

std::vector<Section> figure_sections(const StudyAnalysis& a, const ReportOptions& options,
                                     const std::filesystem::path& figures_dir, const std::filesystem::path& gnuplot) {
  FigureBuilder figures(a, options);
  std::vector<Section> sections;
  sections.push_back(figures.cdfs(true));
  sections.push_back(figures.cdfs(false));
  sections.push_back(figures.repetitions());
  sections.push_back(figures.boxes());
  sections.push_back(figures.correlations());
  if (a.options.ks) sections.push_back(figures.ks());
  if (a.dose) sections.push_back(figures.dose_response());
  if (a.staircase) sections.push_back(figures.staircase_tracks());
  run_gnuplot(figures.script(), figures_dir, gnuplot, options.plot_jobs);
  return sections;
}

}  // namespace hapticlab::analysis::report_parts
