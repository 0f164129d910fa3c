#pragma once
// The study report of `hapticlab analyze`: the same tables and figures in
//   report.html  self-contained (styles and SVG figures inline; opens offline)
//   report.md    Markdown, figures as figures/*.svg next to it
// Tables laid out like the thesis' Tables 3.4–3.7 plus the whole-design test
// and the Appendix I KS intervals; figures like Figures 3-4 to 3-17 and the
// Appendix I plots (list in docs/analysis.md). Figures are drawn by gnuplot
// (report/gnuplot.h), split over a few gnuplot processes that run at once.
#include <cstddef>
#include <filesystem>
#include <vector>

#include "analysis/study/study_analysis.h"

namespace hapticlab::analysis {

struct ReportOptions {
  bool plots = true;                     // false: tables only, gnuplot not needed
  std::size_t max_correlation_plots = 24;
  double correlation_plot_min_abs_r = 0.45;  // the thesis reported |R| > 0.45 (3.4.2.2)
  std::size_t cdf_curve_points = 101;        // points per drawn CDF curve, >= 2
  bool pdf = false;  // also each figure as figures/NAME.pdf (for a paper)
  std::size_t plot_jobs = 0;  // gnuplot processes drawing at once (0: one per core); same figures either way
};

struct ReportFiles {
  std::filesystem::path html;
  std::filesystem::path markdown;
  std::vector<std::filesystem::path> figures;  // SVG files, in report order
};

// Creates out_dir (and out_dir/figures) if needed. Throws DataError naming
// the path when a file cannot be written, or when plots are asked for and
// gnuplot is missing (before writing anything).
ReportFiles write_report(const StudyAnalysis& analysis, const std::filesystem::path& out_dir,
                         const ReportOptions& options = {});

}  // namespace hapticlab::analysis
