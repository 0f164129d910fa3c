#pragma once
// The parts of the study report (report.h) that its files share: the
// document model (sections of tables and figures, rendered as HTML and as
// Markdown) and the functions that make each section. Internal to
// analysis/report/.
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "analysis/report/report.h"
#include "analysis/study/study_analysis.h"

namespace hapticlab::analysis::report_parts {

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

// report_document.cc: numbers and names as the report writes them, and the
// two renderings of the sections.
std::string num(double v, const char* format = "%.3g");
std::string slug(const std::string& s);
std::string html_escape(const std::string& s);
std::string md_escape(const std::string& s);
std::string read_file(const std::filesystem::path& path);
void write_file(const std::filesystem::path& path, const std::string& text);
std::string render_html(const std::string& title, const std::vector<Section>& sections,
                        const std::filesystem::path& out_dir);
std::string render_markdown(const std::string& title, const std::vector<Section>& sections);

// report_statistics_sections.cc: the summary and the comparison tables
// (Tables 3.4-3.6, one value per participant, the whole design).
Section summary_section(const StudyAnalysis& a);
Section friedman_section(const StudyAnalysis& a);
Section pairwise_section(const StudyAnalysis& a, const std::string& task);
Section participant_section(const StudyAnalysis& a, const std::string& task);
Section whole_design_section(const StudyAnalysis& a);

// report_study_sections.cc: correlations (Table 3.7), dose-response,
// staircase, sites, energy and the KS intervals.
std::string correlation_hand(const CorrelationRow& r);
std::string count_of(std::size_t n, const std::string& noun);
std::string abbreviation_key(const std::vector<std::string>& settings);
Section correlation_section(const StudyAnalysis& a, const ReportOptions& report_options);
Section dose_response_section(const StudyAnalysis& a, const std::string& task);
Section staircase_section(const StudyAnalysis& a);
Section sites_section(const StudyAnalysis& a);
Section energy_section(const StudyAnalysis& a);
Section ks_section(const StudyAnalysis& a);

// report_figures.cc: the figure sections, in the report's order, drawn by
// gnuplot (`gnuplot`, found by find_gnuplot) into figures_dir.
std::vector<Section> figure_sections(const StudyAnalysis& a, const ReportOptions& options,
                                     const std::filesystem::path& figures_dir, const std::filesystem::path& gnuplot);

}  // namespace hapticlab::analysis::report_parts
