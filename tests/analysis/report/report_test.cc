#include "analysis/report/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/report/gnuplot.h"
#include "analysis/stats/data_error.h"
#include "study/synthetic_study_db.h"
#include "tests/testing/files.h"

namespace hapticlab::analysis {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

using hapticlab::testing::slurp;

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
    EXPECT_THAT(s, HasSubstr("1 aborted trial was left out"));
    EXPECT_THAT(s, HasSubstr("No Force Feedback (2)"));
    // Beside every table of p values: its effect sizes and the medians.
    EXPECT_THAT(s, HasSubstr("Effect size: Kendall's W"));
    EXPECT_THAT(s, HasSubstr("Effect size: matched-pairs rank-biserial r, and direction"));
    EXPECT_THAT(s, HasSubstr("Median [Q1, Q3] per setting"));
    EXPECT_THAT(s, HasSubstr("95p force [N]"));
  }
}

// The cells of the Markdown table row that starts with `label`.
std::vector<std::string> md_row(const std::string& md, const std::string& label) {
  std::istringstream lines(md);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("| " + label + " |", 0) != 0) continue;
    std::vector<std::string> cells;
    std::istringstream parts(line.substr(1));
    for (std::string cell; std::getline(parts, cell, '|');) {
      const auto b = cell.find_first_not_of(' ');
      const auto e = cell.find_last_not_of(' ');
      cells.push_back(b == std::string::npos ? "" : cell.substr(b, e - b + 1));
    }
    return cells;
  }
  return {};
}

// The printed p ("0.0092", "5E-4", "**0.001", "(0.3)"), stripped of its
// marks, is `p` within half a unit of its last printed digit.
void expect_printed_p(const std::string& cell, double p) {
  std::string digits;
  for (char ch : cell)
    if (ch != '*' && ch != '(' && ch != ')') digits += ch;
  const auto e = digits.find('E');
  const std::string mantissa = digits.substr(0, e);
  const auto point = mantissa.find('.');
  const int decimals = point == std::string::npos ? 0 : static_cast<int>(mantissa.size() - point - 1);
  const int exponent = e == std::string::npos ? 0 : std::stoi(digits.substr(e + 1));
  const double half_unit = 0.5 * std::pow(10.0, exponent - decimals);
  EXPECT_NEAR(std::stod(digits), p, half_unit * (1.0 + 1e-9)) << cell;
}

// Table 3.5's layout: a row per setting, a column per measure in the
// thesis' order, each cell the analysis' p (bold when significant, in
// parentheses when no Table 3.4 test was), N/A without shared blocks.
TEST_F(ReportTest, PairwiseTableCellsAreTheAnalysisResults) {
  ReportOptions o;
  o.plots = false;
  // With --method thesis the thesis' tables come first (md_row finds the first row).
  StudyAnalysis thesis_first = analysis_;
  thesis_first.options.method = ComparisonMethod::kThesis;
  const std::string md = slurp(write_report(thesis_first, dir_.path() / "out", o).markdown);
  const auto header = md_row(md, analysis_.control + " compared to:");
  ASSERT_EQ(header.size(), 6u) << md;
  for (std::size_t k = 0; k < kAllMeasures.size(); ++k) EXPECT_EQ(header[k + 1], measure_label(kAllMeasures[k]));

  const auto row = md_row(md, "No Force Feedback (2)");
  ASSERT_EQ(row.size(), 6u) << md;
  int checked = 0;
  for (const auto& c : analysis_.pairwise) {
    if (c.setting != "No Force Feedback") continue;
    const std::size_t k = static_cast<std::size_t>(
        std::find(kAllMeasures.begin(), kAllMeasures.end(), c.measure) - kAllMeasures.begin());
    const std::string& cell = row[k + 1];
    if (!c.p) {
      EXPECT_EQ(cell, "N/A");
    } else {
      EXPECT_EQ(c.significant, cell.rfind("**", 0) == 0) << cell;
      EXPECT_EQ(c.gated, cell.find('(') != std::string::npos) << cell;
      expect_printed_p(cell, *c.p);
    }
    ++checked;
  }
  EXPECT_EQ(checked, 5);
}

// The default method's table leads the report: each cell the participant-
// level p (bold when significant), the mean difference below it.
TEST_F(ReportTest, ParticipantLevelTableLeadsByDefaultWithTheAnalysisResults) {
  ReportOptions o;
  o.plots = false;
  ASSERT_EQ(analysis_.options.method, ComparisonMethod::kParticipant);
  const std::string md = slurp(write_report(analysis_, dir_.path() / "out", o).markdown);
  EXPECT_LT(md.find("one value per participant, " + analysis_.tasks.front()), md.find("Table 3.4"));
  std::size_t participants = 0;
  for (const auto& c : analysis_.participant_pairwise)
    if (c.setting == "No Force Feedback" && c.task == analysis_.tasks.front())
      participants = std::max(participants, c.participants);
  ASSERT_GT(participants, 0u);
  const auto row = md_row(md, "No Force Feedback (" + std::to_string(participants) + ")");
  ASSERT_EQ(row.size(), 6u) << md;
  int checked = 0;
  for (const auto& c : analysis_.participant_pairwise) {
    if (c.setting != "No Force Feedback" || c.task != analysis_.tasks.front()) continue;
    const std::size_t k = static_cast<std::size_t>(
        std::find(kAllMeasures.begin(), kAllMeasures.end(), c.measure) - kAllMeasures.begin());
    const std::string& cell = row[k + 1];
    ASSERT_TRUE(c.p.has_value());
    EXPECT_EQ(c.significant, cell.rfind("**", 0) == 0) << cell;
    expect_printed_p(cell, *c.p);
    ++checked;
  }
  EXPECT_EQ(checked, 5);
}

// Figures drawn by one gnuplot and by three at once are the same bytes: no
// plot leans on state an earlier plot left behind.
TEST_F(ReportTest, FiguresAreTheSameWhateverTheNumberOfGnuplots) {
  try {
    (void)find_gnuplot();
  } catch (const DataError& e) {
    GTEST_SKIP() << e.what();
  }
  ReportOptions one;
  one.plot_jobs = 1;
  ReportOptions three;
  three.plot_jobs = 3;
  const ReportFiles a = write_report(analysis_, dir_.path() / "one", one);
  const ReportFiles b = write_report(analysis_, dir_.path() / "three", three);
  ASSERT_EQ(a.figures.size(), b.figures.size());
  ASSERT_GE(a.figures.size(), 4u);
  for (std::size_t i = 0; i < a.figures.size(); ++i) {
    EXPECT_EQ(a.figures[i].filename(), b.figures[i].filename());
    EXPECT_EQ(slurp(a.figures[i]), slurp(b.figures[i])) << a.figures[i];
  }
  EXPECT_EQ(slurp(dir_.path() / "one" / "figures" / "plots.gp"), slurp(dir_.path() / "three" / "figures" / "plots.gp"));
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
  // Every id once in the page, though gnuplot gives each SVG the same ones.
  std::map<std::string, int> ids;
  for (const char* opener : {" id=\"", " id='"}) {
    for (auto pos = html.find(opener); pos != std::string::npos; pos = html.find(opener, pos + 1)) {
      const auto begin = pos + std::strlen(opener);
      ++ids[html.substr(begin, html.find_first_of("\"'", begin) - begin)];
    }
  }
  EXPECT_GT(ids.size(), files.figures.size());
  for (const auto& [id, count] : ids) EXPECT_EQ(count, 1) << id;
  // The script stays for restyling by hand.
  EXPECT_TRUE(std::filesystem::exists(dir_.path() / "out" / "figures" / "plots.gp"));
}

// For a paper: every figure also as a complete PDF beside its SVG.
TEST_F(ReportTest, EveryFigureAlsoAsPdf) {
  try {
    (void)find_gnuplot();
  } catch (const DataError& e) {
    GTEST_SKIP() << e.what();
  }
  ReportOptions o;
  o.pdf = true;
  const ReportFiles files = write_report(analysis_, dir_.path() / "out", o);
  ASSERT_FALSE(files.figures.empty());
  for (const auto& svg : files.figures) {
    std::filesystem::path pdf = svg;
    pdf.replace_extension(".pdf");
    ASSERT_TRUE(std::filesystem::exists(pdf)) << pdf;
    const std::string text = slurp(pdf);
    EXPECT_EQ(text.substr(0, 5), "%PDF-") << pdf;
    EXPECT_NE(text.find("%%EOF", text.size() - 32), std::string::npos) << pdf;
  }
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

// Split over parts: every plot lands in exactly one part, in its original
// order, with the datablocks it names and no other ($d1 is not $d10).
TEST(GnuplotTest, SplitGivesEachPartOnlyTheDataItsPlotsName) {
  GnuplotScript s;
  s.add_datablock("d1", "1 1\n");
  s.add_datablock("d10", std::string(50000, '7') + "\n");  // heavy: its plot gets a part of its own
  s.add_plot("a.svg", "plot $d1 with points");
  s.add_plot("b.svg", "plot $d10 with points");
  s.add_plot("c.svg", "plot $d1 with lines");
  const auto parts = s.split(2);
  ASSERT_EQ(parts.size(), 2u);
  const std::string& heavy = parts[0].find("b.svg") != std::string::npos ? parts[0] : parts[1];
  const std::string& light = &heavy == &parts[0] ? parts[1] : parts[0];
  EXPECT_THAT(heavy, HasSubstr("$d10 << EOD"));
  EXPECT_THAT(heavy, Not(HasSubstr("$d1 << EOD")));
  EXPECT_THAT(light, HasSubstr("$d1 << EOD"));
  EXPECT_THAT(light, Not(HasSubstr("$d10 << EOD")));
  EXPECT_LT(light.find("a.svg"), light.find("c.svg"));
  EXPECT_EQ(s.split(1).size(), 1u);
  EXPECT_EQ(s.split(1)[0], s.text());
  EXPECT_EQ(s.split(99).size(), 3u);  // never more parts than plots
}

// One gnuplot error in any part: nothing reaches the figures directory, and
// the message is gnuplot's own.
TEST(GnuplotTest, AFailingPartLeavesNoFigure) {
  std::filesystem::path gnuplot;
  try {
    gnuplot = find_gnuplot();
  } catch (const DataError& e) {
    GTEST_SKIP() << e.what();
  }
  const auto dir = std::filesystem::temp_directory_path() / ("gp_fail_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  GnuplotScript s;
  for (int i = 0; i < 4; ++i) s.add_plot("ok" + std::to_string(i) + ".svg", "plot x");
  s.add_plot("bad.svg", "plot $no_such_block with lines");
  EXPECT_THAT([&] { run_gnuplot(s, dir, gnuplot, 3); },
              ::testing::ThrowsMessage<DataError>(HasSubstr("no_such_block")));
  std::vector<std::string> left;
  for (const auto& e : std::filesystem::directory_iterator(dir)) left.push_back(e.path().filename().string());
  std::filesystem::remove_all(dir);
  EXPECT_TRUE(left.empty()) << left.size() << " files left, first " << (left.empty() ? "" : left[0]);
}

// Ids and the references to them get the prefix; names that merely end in
// "id" (grid=) and the XML prolog do not survive.
TEST(GnuplotTest, InlineSvgPrefixesIdsAndReferences) {
  const std::string svg =
      "<?xml version=\"1.0\"?>\n<svg id=\"gnuplot_canvas\" grid='x'>\n<defs><path id='gpPt0'/>"
      "<use xlink:href='#gpPt0' id='gpPt6'/></defs><g clip-path=\"url(#c1)\"><use href=\"#gpPt6\"/></g></svg>";
  EXPECT_EQ(inline_svg(svg, "f3_"),
            "<svg id=\"f3_gnuplot_canvas\" grid='x'>\n<defs><path id='f3_gpPt0'/>"
            "<use xlink:href='#f3_gpPt0' id='f3_gpPt6'/></defs><g clip-path=\"url(#f3_c1)\"><use href=\"#f3_gpPt6\"/>"
            "</g></svg>");
}

// Relative luminance (WCAG 2) of an sRGB colour given as 0-255 channels.
double luminance(int r, int g, int b) {
  auto lin = [](int c) {
    const double v = c / 255.0;
    return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
  };
  return 0.2126 * lin(r) + 0.7152 * lin(g) + 0.0722 * lin(b);
}

// Eight curves drawn by gnuplot with the report's line types: every stroke
// colour has at least WCAG's 3:1 contrast against the white background
// (gnuplot's default yellow, rgb(240,228,66)... has 1.3:1), and no two of the
// eight are the same.
TEST(GnuplotTest, LineColoursContrastWithWhite) {
  std::filesystem::path gnuplot;
  try {
    gnuplot = find_gnuplot();
  } catch (const DataError& e) {
    GTEST_SKIP() << e.what();
  }
  const auto dir = std::filesystem::temp_directory_path() / ("gp_colours_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  GnuplotScript s;
  s.add_plot("c.svg", "plot for [i=1:8] i*x with lines title sprintf('c%d', i)");
  run_gnuplot(s, dir, gnuplot);
  const std::string svg = slurp(dir / "c.svg");
  std::filesystem::remove_all(dir);
  std::set<std::string> colours;
  for (auto pos = svg.find("stroke='rgb("); pos != std::string::npos; pos = svg.find("stroke='rgb(", pos + 1)) {
    int r = 0, g = 0, b = 0;
    ASSERT_EQ(std::sscanf(svg.c_str() + pos + 12, "%d, %d, %d", &r, &g, &b), 3);
    if (r == 255 && g == 255 && b == 255) continue;  // the background
    colours.insert(std::to_string(r) + "," + std::to_string(g) + "," + std::to_string(b));
    EXPECT_GE(1.05 / (luminance(r, g, b) + 0.05), 3.0) << "rgb(" << r << "," << g << "," << b << ")";
  }
  EXPECT_GE(colours.size(), 8u);
}

}  // namespace
}  // namespace hapticlab::analysis
