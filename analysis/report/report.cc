// The study report: its sections in order, written as HTML and Markdown
// (each section's file: report_parts.h).
#include "analysis/report/report.h"

#include <filesystem>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "analysis/report/gnuplot.h"
#include "analysis/report/report_parts.h"
#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {

ReportFiles write_report(const StudyAnalysis& a, const std::filesystem::path& out_dir, const ReportOptions& options) {
  using namespace report_parts;
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
    for (auto& s : figure_sections(a, options, out_dir / "figures", gnuplot)) sections.push_back(std::move(s));
    const std::string key = abbreviation_key(a.settings);
    for (auto& s : sections)
      if (!s.figures.empty() && !key.empty()) s.intro += (s.intro.empty() ? "" : " ") + key;
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
