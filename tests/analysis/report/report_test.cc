#include "analysis/report/report.h"

#include <fstream>
#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/report/gnuplot.h"
#include "analysis/stats/data_error.h"
#include "study/synthetic_study_db.h"

namespace hapticlab::analysis {
namespace {

using ::testing::HasSubstr;

std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class ReportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    testing::build_synthetic_study(dir_.path() / "study.db");
    AnalysisOptions o;
    o.ks_block_length = 2;
    o.ks_stride = 1;
    o.ks_resamples = 100;
    analysis_ = analyze_study_file(dir_.path() / "study.db", o);
  }
  testing::ScratchDir dir_;
  StudyAnalysis analysis_;
};

TEST_F(ReportTest, TablesOnlyWithoutGnuplot) {
  ReportOptions o;
  o.plots = false;
  const ReportFiles files = write_report(analysis_, dir_.path() / "out", o);
  EXPECT_TRUE(files.figures.empty());
  const std::string html = slurp(files.html);
  const std::string md = slurp(files.markdown);
  for (const std::string& s : {html, md}) {
    EXPECT_THAT(s, HasSubstr("Table 3.4"));
    EXPECT_THAT(s, HasSubstr("Table 3.5"));
    EXPECT_THAT(s, HasSubstr("Table 3.7"));
    EXPECT_THAT(s, HasSubstr("All participants at once"));
    EXPECT_THAT(s, HasSubstr("Appendix I"));
    EXPECT_THAT(s, HasSubstr("1 aborted trial(s) were left out"));
    EXPECT_THAT(s, HasSubstr("No Force Feedback (2)"));
  }
}

// Every figure the report lists exists as an SVG, sits inline in the HTML
// (nothing external to load) and is linked from the Markdown.
TEST_F(ReportTest, FiguresInlineInHtmlAndLinkedFromMarkdown) {
  try {
    (void)find_gnuplot();
  } catch (const DataError& e) {
    GTEST_SKIP() << e.what();
  }
  const ReportFiles files = write_report(analysis_, dir_.path() / "out", {});
  const std::string html = slurp(files.html);
  const std::string md = slurp(files.markdown);
  // 2 quantities × 2 participants × 2 hands CDFs, 9 per-repetition plots
  // (4 per-hand measures × 2 hands + completion time), 3 box plots, 2 KS
  // plots, and the correlations with |r| >= 0.45.
  std::size_t correlations = 0;
  for (const auto& r : analysis_.correlations)
    if (r.result && std::abs(r.result->r) >= 0.45) ++correlations;
  EXPECT_EQ(files.figures.size(), 8u + 9u + 3u + 2u + std::min<std::size_t>(correlations, 24));
  std::size_t svg_count = 0;
  for (auto pos = html.find("<svg"); pos != std::string::npos; pos = html.find("<svg", pos + 1)) ++svg_count;
  EXPECT_EQ(svg_count, files.figures.size());
  EXPECT_THAT(html, ::testing::Not(HasSubstr("<img")));
  EXPECT_THAT(html, ::testing::Not(HasSubstr("<?xml")));
  for (const auto& f : files.figures) {
    ASSERT_TRUE(std::filesystem::exists(f)) << f;
    EXPECT_THAT(slurp(f), HasSubstr("<svg"));
    EXPECT_THAT(md, HasSubstr("(figures/" + f.filename().string() + ")"));
  }
  for (const char* name : {"cdf_force_dissection_P1_left.svg", "cdf_speed_dissection_P2_right.svg",
                           "reps_force_p95_N_dissection_left.svg", "reps_completion_time_s_dissection.svg",
                           "box_force_median_N_hands.svg", "box_completion_time_participants.svg",
                           "ks_force_dissection.svg"}) {
    EXPECT_TRUE(std::filesystem::exists(dir_.path() / "out" / "figures" / name)) << name;
  }
  // The script stays for restyling by hand.
  EXPECT_TRUE(std::filesystem::exists(dir_.path() / "out" / "figures" / "plots.gp"));
}

TEST_F(ReportTest, MissingGnuplotIsAClearErrorBeforeAnythingIsWritten) {
  ::setenv("HAPTICLAB_GNUPLOT", (dir_.path() / "no-gnuplot-here").c_str(), 1);
  EXPECT_THAT([&] { (void)write_report(analysis_, dir_.path() / "out2", {}); },
              ::testing::ThrowsMessage<DataError>(HasSubstr("HAPTICLAB_GNUPLOT")));
  ::unsetenv("HAPTICLAB_GNUPLOT");
  EXPECT_FALSE(std::filesystem::exists(dir_.path() / "out2"));
}

TEST(GnuplotTest, QuotesAndScript) {
  EXPECT_EQ(gnuplot_quote("a \"b\" \\c"), "\"a \\\"b\\\" \\\\c\"");
  GnuplotScript s;
  s.add_datablock("d0", "1 2\n");
  s.add_plot("x.svg", "plot $d0 with points");
  EXPECT_THAT(s.text(), HasSubstr("$d0 << EOD\n1 2\nEOD\n"));
  EXPECT_THAT(s.text(), HasSubstr("set output \"x.svg\""));
  EXPECT_EQ(s.outputs(), (std::vector<std::string>{"x.svg"}));
}

}  // namespace
}  // namespace hapticlab::analysis
