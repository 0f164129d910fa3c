#include "analysis/learning/learning_analysis.h"

#include <cmath>
#include <filesystem>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/io/long_csv.h"
#include "analysis/learning/learning_figures.h"
#include "analysis/report/gnuplot.h"
#include "analysis/stats/data_error.h"

namespace hapticlab::analysis::learning {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// P1 and P2 follow 20 + 40 n^-0.8 exactly over 12 training trials; P3 has
// only 4 (too few for a fit). Criterion 30 s.
TrialTable sample_table() {
  std::ostringstream csv;
  csv.precision(17);
  csv << "participant,group,phase,trial,completion_time_s\n";
  for (const char* id : {"P1", "P2"})
    for (int n = 1; n <= 12; ++n)
      csv << id << ',' << (id[1] == '1' ? "hifi" : "lofi") << ",training," << n << ','
          << 20 + 40 * std::pow(n, -0.8) << '\n';
  for (int n = 1; n <= 4; ++n) csv << "P3,lofi,training," << n << ',' << 60 - n << '\n';
  csv << "P3,lofi,pre,1,70\n";
  return read_trial_table(LongCsv::parse(csv.str(), "trials.csv"), TrialColumns{});
}

TEST(LearningAnalysis, CurvesCusumCsvAndFigures) {
  CusumCriterion criterion;
  criterion.criterion = 30.0;
  criterion.spec = {0.1, 0.3, 0.05, 0.2, {}};
  const LearningAnalysis a = analyze_learning(sample_table(), Phase::kTraining, criterion);
  ASSERT_EQ(a.participants.size(), 3u);
  EXPECT_EQ(a.participants[0].curve.chosen, CurveFamily::kPower);
  EXPECT_NEAR(a.participants[0].curve.fit(CurveFamily::kPower).a, 20.0, 1e-6);
  EXPECT_FALSE(a.participants[2].curve.chosen);
  std::ostringstream curves;
  write_curves_csv(a, curves);
  EXPECT_THAT(curves.str(), HasSubstr("P1,hifi,power,ok,1,12,20"));
  EXPECT_THAT(curves.str(), HasSubstr("P3,lofi,power,too_few_trials,0,4,"));
  std::ostringstream cusum;
  write_cusum_csv(a, cusum);
  // P1's trial 1: 60 s > 30 s, a failure: score 1 - s = 0.813831.
  EXPECT_THAT(cusum.str(), HasSubstr("P1,hifi,1,60,1,0.813831"));

  const fs::path dir = fs::path(::testing::TempDir()) / "learning_figures";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const auto files = write_learning_figures(a, dir, find_gnuplot());
  for (const char* f : {"curve_1.svg", "cusum_1.svg", "curve_3.svg", "group_medians.svg", "plots.gp"}) {
    EXPECT_TRUE(fs::exists(dir / f)) << f;
    EXPECT_NE(std::find(files.begin(), files.end(), f), files.end()) << f;
  }
  fs::remove_all(dir);

  EXPECT_THROW(analyze_learning(sample_table(), Phase::kRetention, std::nullopt), DataError);
  criterion.spec.p1 = 0.05;
  EXPECT_THROW(analyze_learning(sample_table(), Phase::kTraining, criterion), DataError);
}

}  // namespace
}  // namespace hapticlab::analysis::learning
