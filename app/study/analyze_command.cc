#include "app/study/analyze_command.h"

#include <cstdio>
#include <iostream>
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "app/cli/cli_checks.h"
#include "app/cli/option_shapes.h"
#include "core/common/output_record.h"
#include "analysis/study/group_design.h"
#include "analysis/study/headline_format.h"
#include "analysis/report/gnuplot.h"
#include "analysis/report/report.h"
#include "analysis/stats/data_error.h"
#include "analysis/study/metrics_csv.h"
#include "analysis/study/study_analysis.h"

namespace hapticlab::app {
namespace an = hapticlab::analysis;

namespace {

struct AnalyzeOptions {
  std::string db;
  std::string out;
  std::int64_t study = -1;
  std::string percentile_method = "matlab";
  std::string method = "participant";
  bool include_aborted = false;
  std::string control;
  double alpha = 0.05;
  double min_force_mN = 1.0;
  bool no_ks = false;
  std::size_t ks_resamples = 1000;
  std::size_t ks_stride = 50;
  std::size_t ks_block = 10;
  std::uint64_t seed = 1;
  bool no_plots = false;
  std::size_t jobs = 0;
  bool pdf = false;
  bool quiet = false;
  bool json = false;
};

// A merged multi-site study's participants by site and each task's verdict
// (analysis/study/site_balance.h); null for a study never merged.
nlohmann::json sites_json(const an::StudyAnalysis& a) {
  if (a.participant_sites.empty()) return nullptr;
  nlohmann::json tasks = nlohmann::json::array();
  for (const an::SiteBalance& b : a.site_balance) {
    nlohmann::json confounded = nlohmann::json::array();
    for (const auto& [setting, site] : b.confounded) confounded.push_back({{"setting", setting}, {"site", site}});
    tasks.push_back({{"task", b.task}, {"sites", b.sites}, {"settings", b.settings}, {"participants", b.counts},
                     {"balanced", b.balanced()}, {"confounded", confounded}, {"unbalanced", b.unbalanced},
                     {"verdict", b.verdict()}});
  }
  return {{"participants", a.participant_sites}, {"tasks", tasks}};
}

// The summary a script needs: what was analysed, the whole-design and
// pairwise results, and where the files are. The report has everything.
nlohmann::json analyze_optional(const std::optional<double>& v) { return v ? nlohmann::json(*v) : nlohmann::json(); }

nlohmann::json whole_design_json(const an::StudyAnalysis& a) {
  nlohmann::json whole = nlohmann::json::array();
  for (const an::WholeDesignRow& r : a.whole_design) {
    nlohmann::json row = {{"task", r.task}, {"measure", an::measure_column(r.measure)}};
    if (r.test.result) {
      row["method"] = r.test.result->method;
      row["statistic"] = r.test.result->statistic;
      row["df"] = r.test.result->df;
      row["p"] = r.test.result->p;
    } else {
      row["note"] = r.test.note;
    }
    whole.push_back(row);
  }
  return whole;
}

// The pairwise cells: the thesis' procedure, then one value per participant.
std::pair<nlohmann::json, nlohmann::json> pairwise_json(const an::StudyAnalysis& a) {
  nlohmann::json pairwise = nlohmann::json::array();
  for (const an::PairwiseCell& c : a.pairwise)
    pairwise.push_back({{"task", c.task}, {"setting", c.setting}, {"measure", an::measure_column(c.measure)},
                        {"p", analyze_optional(c.p)}, {"significant", c.significant}, {"participants", c.participants},
                        {"note", c.note}});
  nlohmann::json by_participant = nlohmann::json::array();
  for (const an::ParticipantPairwiseCell& c : a.participant_pairwise)
    by_participant.push_back({{"task", c.task}, {"setting", c.setting}, {"measure", an::measure_column(c.measure)},
                              {"p", analyze_optional(c.p)}, {"significant", c.significant},
                              {"participants", c.participants}, {"mean_difference", analyze_optional(c.mean_difference)},
                              {"note", c.note}});
  return {pairwise, by_participant};
}

// Null unless a dose-response study.
nlohmann::json dose_json(const an::StudyAnalysis& a) {
  nlohmann::json dose;
  if (!a.dose) return dose;
  nlohmann::json levels = nlohmann::json::array();
  for (const an::DoseLevel& l : a.dose->levels) levels.push_back({{"setting", l.setting}, {"strength", l.strength}});
  nlohmann::json rows = nlohmann::json::array();
  for (const an::DoseResponseRow& r : a.dose_response)
    rows.push_back({{"task", r.task}, {"measure", an::measure_column(r.measure)}, {"trend_p", analyze_optional(r.trend_p)},
                    {"mean_slope", r.mean_slope}, {"participants", r.slopes},
                    {"trend_significant", r.trend_significant},
                    {"smallest_significant_strength", analyze_optional(r.smallest_significant_strength)},
                    {"note", r.note}});
  dose = {{"field", a.dose->field}, {"levels", levels}, {"rows", rows}};
  return dose;
}

// Null unless a staircase study.
nlohmann::json staircase_rows_json(const an::StudyAnalysis& a) {
  nlohmann::json staircases;
  if (!a.staircase) return staircases;
  staircases = nlohmann::json::array();
  for (const an::StaircaseRow& r : a.staircases)
    staircases.push_back({{"participant", r.participant}, {"baseline", r.baseline},
                          {"trials", r.trials.size()}, {"reversals", r.reversals}, {"finished", r.finished},
                          {"stop_reason", r.stop_reason}, {"threshold", analyze_optional(r.threshold)}, {"note", r.note}});
  return staircases;
}

nlohmann::json summary_json(const an::StudyAnalysis& a, const std::filesystem::path& out,
                            const an::ReportFiles& files) {
  const auto [pairwise, by_participant] = pairwise_json(a);
  return {{"study", a.study_name},
          {"control", a.control},
          {"method", an::comparison_method_name(a.options.method)},
          {"trials", {{"analysed", a.counts.analysed}, {"complete", a.counts.complete},
                      {"aborted_excluded", a.counts.aborted_excluded},
                      {"aborted_included", a.counts.aborted_included}, {"not_run", a.counts.not_run},
                      {"without_window", a.counts.without_window}, {"damaged_chunks", a.counts.damaged_chunks},
                      {"staircase", a.counts.staircase}}},
          {"sidak_level", a.sidak_level},
          {"whole_design", whole_design_json(a)},
          {"pairwise", pairwise},  // the thesis' procedure
          {"participant_pairwise", by_participant},
          {"dose_response", dose_json(a)},
          {"staircase", staircase_rows_json(a)},
          {"sites", sites_json(a)},
          {"sessions", {{"rate", a.session_conditions.rate_text},
                        {"who_held_the_device", a.session_conditions.participant_text},
                        {"warnings", a.session_conditions.warnings}}},
          {"files", {{"metrics_csv", (out / "metrics.csv").string()}, {"html", files.html.string()},
                     {"markdown", files.markdown.string()}, {"figures", files.figures.size()}}}};
}

// A between-group design: the transfer analysis and learning curves
// (analysis/study/group_design.h) instead of the within-participant report.
std::vector<std::filesystem::path> write_group_design_study(const an::StudyAnalysis& analysis,
                                                            const std::filesystem::path& out, bool plots, bool json,
                                                            bool quiet) {
  const std::vector<an::TaskGroupAnalysis> tasks = an::analyze_group_design(analysis);
  const an::GroupDesignFiles files = an::write_group_design(tasks, out, plots ? an::find_gnuplot() : "");
  if (json) {
    nlohmann::json written = nlohmann::json::array();
    for (const auto& f : files.written) written.push_back(f.string());
    std::printf("%s\n", nlohmann::json{{"group_design", true}, {"metrics", (out / "metrics.csv").string()},
                                        {"transfer", files.markdown.string()}, {"files", written}}
                            .dump(2)
                            .c_str());
    return files.written;
  }
  if (!quiet) {
    for (const an::TaskGroupAnalysis& t : tasks) {
      std::printf("\n%s:\n", t.task.c_str());
      if (t.transfer) an::transfer::write_transfer_text(*t.transfer, std::cout);
      else std::printf("no transfer analysis: %s\n", t.transfer_refusal.c_str());
    }
    std::fflush(stdout);
  }
  std::printf("\nbetween-group design: the within-participant tables do not apply; wrote %s, %s and %zu more "
              "file(s) in %s\n", (out / "metrics.csv").c_str(), files.markdown.c_str(), files.written.size() - 1,
              out.c_str());
  return files.written;
}

std::vector<std::filesystem::path> write_within_participant_report(const an::StudyAnalysis& analysis,
                                                                   const std::filesystem::path& out,
                                                                   const an::ReportOptions& report,
                                                                   const AnalyzeOptions& o);

an::AnalysisOptions analysis_options(const AnalyzeOptions& o) {
  an::AnalysisOptions options;
  if (o.study >= 0) options.study_id = o.study;
  options.percentile_method = an::parse_percentile_method(o.percentile_method);
  options.method = an::parse_comparison_method(o.method);
  options.include_aborted = o.include_aborted;
  options.control_setting = o.control;
  options.alpha = o.alpha;
  options.min_force_N = o.min_force_mN * 1e-3;
  options.ks = !o.no_ks;
  options.ks_resamples = o.ks_resamples;
  options.ks_stride = o.ks_stride;
  options.ks_block_length = o.ks_block;
  options.seed = o.seed;
  options.threads = o.jobs;
  // The within-trial quantile grids feed only the CDF figures.
  if (o.no_plots) options.cdf_points = 0;
  options.validate();
  return options;
}

// Said on stderr whatever the output format: the damaged chunks left out,
// and a study whose sessions differ in more than their settings
// (session_conditions.h).
void warn_about_the_data(const an::StudyAnalysis& analysis) {
  for (const an::TrialRecord& t : analysis.trials)
    for (const std::string& c : t.damaged_chunks)
      std::fprintf(stderr, "warning: left out damaged sample chunk: %s; trial %lld's measures are missing\n",
                   c.c_str(), static_cast<long long>(t.trial_id));
  for (const std::string& w : analysis.session_conditions.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  std::fflush(stderr);
}

void run_analyze(const AnalyzeOptions& o) {
  const an::AnalysisOptions options = analysis_options(o);
  an::ReportOptions report;
  report.plots = !o.no_plots;
  report.pdf = o.pdf;
  report.plot_jobs = o.jobs;
  if (o.pdf && o.no_plots) throw CLI::ValidationError("--pdf", "writes the figures as PDF too; --no-plots writes none");
  // Fail on a missing gnuplot before minutes of analysis, not after.
  if (report.plots) an::find_gnuplot();

  const an::StudyAnalysis analysis = an::analyze_study_file(o.db, options);
  warn_about_the_data(analysis);
  const std::filesystem::path out(o.out);
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) throw an::DataError("--out is '" + o.out + "', but it cannot be created: " + ec.message());
  an::write_metrics_csv(analysis, out / "metrics.csv");
  std::vector<std::filesystem::path> written =
      analysis.group_design ? write_group_design_study(analysis, out, report.plots, o.json, o.quiet)
                            : write_within_participant_report(analysis, out, report, o);
  written.push_back(out / "metrics.csv");
  // One run's results in --out: another study's report, the figures of a
  // run before --no-plots, are gone once this run's files are in place.
  if (const auto removed = replace_output_record(out, written); !removed.empty())
    std::fprintf(stderr, "removed %zu file(s) an earlier analyze wrote in %s and this one did not (%s%s)\n",
                 removed.size(), o.out.c_str(), removed.front().c_str(), removed.size() > 1 ? ", ..." : "");
  // The outputs hold everything that could be read; trials whose measures
  // are missing change the results, which a script must not miss: exit 1,
  // as export does.
  if (analysis.counts.damaged_chunks > 0) {
    std::fflush(stdout);
    throw std::runtime_error(o.db + ": " + std::to_string(analysis.counts.damaged_chunks) +
                             " damaged sample chunk(s) left out, listed above: the results in " + o.out +
                             " are without those trials' measures; `hapticlab study check --db " + o.db +
                             "` lists every damaged chunk");
  }
}

// The report's files: the HTML and markdown, the figures (SVG, PDF with
// --pdf) and their script.
std::vector<std::filesystem::path> report_files(const an::ReportFiles& files, const an::ReportOptions& report,
                                                const std::filesystem::path& out) {
  std::vector<std::filesystem::path> written = {files.html, files.markdown};
  for (const std::filesystem::path& svg : files.figures) {
    written.push_back(svg);
    if (report.pdf) written.push_back(std::filesystem::path(svg).replace_extension(".pdf"));
  }
  if (report.plots) written.push_back(out / "figures" / "plots.gp");
  return written;
}

std::vector<std::filesystem::path> write_within_participant_report(const an::StudyAnalysis& analysis,
                                                                   const std::filesystem::path& out,
                                                                   const an::ReportOptions& report,
                                                                   const AnalyzeOptions& o) {
  const an::ReportFiles files = an::write_report(analysis, out, report);
  const std::vector<std::filesystem::path> written = report_files(files, report, out);
  if (o.json) {
    std::printf("%s\n", summary_json(analysis, out, files).dump(2).c_str());
    return written;
  }
  if (!o.quiet) std::fputs(an::format_headline_tables(analysis).c_str(), stdout);
  // A merged multi-site study: whether its sites are confounded with its
  // settings, said even with --quiet (it changes what the results mean).
  for (const an::SiteBalance& b : analysis.site_balance)
    std::printf("%s%s: sites %s\n", b.balanced() ? "" : "warning: ", b.task.c_str(), b.verdict().c_str());
  std::printf("\nwrote %s, %s, %s and %zu figure(s) in %s\n", (out / "metrics.csv").c_str(), files.html.c_str(),
              files.markdown.c_str(), files.figures.size(), (out / "figures").c_str());
  return written;
}

}  // namespace

void add_analyze_command(CLI::App& app) {
  auto opt = std::make_shared<AnalyzeOptions>();
  CLI::App* cmd = app.add_subcommand(
      "analyze",
      "Analyse a study database the thesis' way: per-trial metrics (completion time, median and 95th "
      "percentile tip force, median tip speed, path length), Friedman per participant (Table 3.4), "
      "control vs each setting at the Sidak level (Tables 3.5/3.6), Durbin / Skillings-Mack over all "
      "participants, trial-number correlations (Table 3.7), KS with the moving block bootstrap "
      "(Appendix I). Writes DIR/metrics.csv, DIR/report.html (self-contained), DIR/report.md and "
      "DIR/figures/*.svg (drawn by gnuplot), and prints Tables 3.4-3.6.");
  cmd->add_option("--db", opt->db, "Study database (SQLite) to read; it is never modified")->required();
  cmd->add_option("--out", opt->out, "Directory for metrics.csv, report.html, report.md and figures/ (created)")
      ->required();
  cmd->add_option("--study", opt->study, "Study id, required when the database holds more than one study");
  cmd->add_option("--percentile-method", opt->percentile_method,
                  "Percentile definition for every median, 95th percentile and quartile: matlab (MATLAB "
                  "prctile, Hyndman-Fan type 5, the thesis' tool), r7 (R/numpy default), r6, nearest")
      ->capture_default_str();
  cmd->add_option("--method", opt->method,
                  "How each setting is compared with the control, in the tables and the report: participant "
                  "(one value per participant, exact sign-flip test; keeps the false-positive rate at alpha, "
                  "docs/analysis.md) or thesis (the thesis' pairwise Friedman, repetitions and hands as "
                  "replicates). Both are computed; this picks the one shown first")
      ->capture_default_str()
      ->check(CLI::IsMember({"participant", "thesis"}));
  cmd->add_flag("--include-aborted", opt->include_aborted,
                "Analyse aborted trials too (by default they are left out and counted in the report)");
  cmd->add_option("--control", opt->control,
                  "Control setting for the pairwise and KS comparisons (default: the setting named like "
                  "'High Fidelity')");
  cmd->add_option("--alpha", opt->alpha,
                  "Significance level, in (0, 1): per-participant tests at alpha, pairwise ones at the Sidak "
                  "level 1-(1-alpha)^(1/m), m = number of settings - 1")
      ->capture_default_str();
  cmd->add_option("--min-force-mN", opt->min_force_mN,
                  "Contact threshold: samples with |F| below it (in mN, >= 0) are left out of the force "
                  "percentiles (thesis: 1 mN)")
      ->capture_default_str();
  cmd->add_flag("--no-ks", opt->no_ks, "Skip the Kolmogorov-Smirnov bootstrap (Appendix I)");
  cmd->add_option("--ks-resamples", opt->ks_resamples, "KS bootstrap resamples per comparison, >= 100 (thesis: 1000)")
      ->capture_default_str();
  cmd->add_option("--ks-stride", opt->ks_stride,
                  "Keep every k-th sample (k >= 1) of each force and speed series for the KS bootstrap; 50 "
                  "turns a 1 kHz log into 20 Hz, 1200-2400 samples per 1-2 minute trial")
      ->capture_default_str();
  cmd->add_option("--ks-block", opt->ks_block,
                  "Moving block length in kept samples, >= 1 (10 at stride 50 and 1 kHz = 0.5 s); should "
                  "cover the series' autocorrelation")
      ->capture_default_str();
  add_seed_option(*cmd, opt->seed, "Seed of the KS bootstrap; same seed and data, same result");
  cmd->add_flag("--no-plots", opt->no_plots, "Write the report without figures (gnuplot not needed)");
  cmd->add_flag("--pdf", opt->pdf, "Also write each figure as figures/NAME.pdf (vector, for a paper)");
  add_jobs_option(*cmd, opt->jobs, "Trials read, and figures drawn (gnuplot processes), in parallel (0: one "
                  "per core); the results do not depend on it")->capture_default_str();
  cmd->add_flag("--json", opt->json,
                "Print a JSON summary (counts, whole-design and pairwise results, files) instead of the tables");
  cmd->add_flag("--quiet", opt->quiet, "Do not print the headline tables");
  cmd->callback([opt] { run_analyze(*opt); });
}

}  // namespace hapticlab::app
