// The report of plan power's predicted change (issue 35 §4): one study's
// change per setting and measure, its summary over studies, the trials
// that timed out, and the tables, which say they are the model's and take a
// second variant (a fitted population's uncertainty) beside the first.
#include "planning/comparison_report.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "planning/change_summary.h"
#include "planning/study_change.h"

namespace hapticlab::planning {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

analysis::TrialRecord timed_trial(const std::string& participant, const std::string& setting, double time_s,
                            double p95_left_N, double p95_right_N) {
  analysis::TrialRecord t;
  t.participant = participant;
  t.task = "clip";
  t.setting = setting;
  t.status = "complete";
  t.window = analysis::TaskWindow{0.0, time_s};
  t.hands[0].force_p95_N = p95_left_N;
  t.hands[1].force_p95_N = p95_right_N;
  return t;
}

// Per participant the ratio of their medians (repetitions, and both hands
// for a per-hand measure), then the median over participants; a
// participant without the control, or without the setting, is left out.
TEST(ComparisonReportTest, AStudysChangeIsTheMedianOfItsParticipantsRatios) {
  analysis::StudyAnalysis a;
  a.control = "High Fidelity";
  a.tasks = {"clip"};
  a.settings = {"High Fidelity", "Falcon"};
  a.trials = {timed_trial("A", "High Fidelity", 10, 1.0, 1.0), timed_trial("A", "High Fidelity", 12, 1.0, 3.0),
              timed_trial("A", "Falcon", 22, 3.0, 3.0),         timed_trial("B", "High Fidelity", 10, 2.0, 2.0),
              timed_trial("B", "Falcon", 15, 2.0, 2.0),         timed_trial("C", "Falcon", 99, 9.0, 9.0),
              timed_trial("D", "High Fidelity", 10, 1.0, 1.0)};
  const std::vector<ChangeOutcome> changes = changes_of(a);
  auto find = [&](const std::string& measure) {
    for (const ChangeOutcome& c : changes)
      if (c.measure == measure) return c;
    ADD_FAILURE() << "no change for " << measure;
    return ChangeOutcome{};
  };
  // Time: A 22 / median(10, 12) = 2, B 15 / 10 = 1.5: median 1.75.
  EXPECT_EQ(find("completion_time_s").participants, 2);
  EXPECT_DOUBLE_EQ(find("completion_time_s").ratio, 1.75);
  // 95p force, both hands pooled: A 3 / median(1, 1, 1, 3) = 3, B 1: median 2.
  EXPECT_DOUBLE_EQ(find("force_p95_N").ratio, 2.0);
  for (const ChangeOutcome& c : changes) EXPECT_EQ(c.setting, "Falcon");
  a.control.clear();
  EXPECT_TRUE(changes_of(a).empty());
}

TEST(ComparisonReportTest, StudiesAreSummarizedByTheirMedianAndTheMiddle95Percent) {
  std::vector<StudyOutcome> outcomes;
  for (int i = 0; i < 41; ++i) {
    StudyOutcome o;
    o.participants = 8;
    o.index = i;
    o.changes.push_back({"clip", "Falcon", "completion_time_s", 8, 1.0 + 0.01 * i});  // +0 % .. +40 %
    o.setting_trials.push_back({"clip", "Falcon", 16, i < 4 ? 1 : 0});
    o.setting_trials.push_back({"clip", "High Fidelity", 16, 0});
    outcomes.push_back(o);
  }
  const std::vector<ChangeRow> rows = summarize_changes(outcomes, {"High Fidelity", "Falcon"});
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].studies, 41);
  EXPECT_NEAR(rows[0].median, 0.20, 1e-12);
  EXPECT_NEAR(rows[0].low, 0.00525, 1e-12);  // MATLAB percentiles: x(i) at 100 (i - 0.5) / 41
  EXPECT_NEAR(rows[0].high, 0.39475, 1e-12);
  const std::vector<TimeoutRow> timeouts = summarize_timeouts(outcomes, {"High Fidelity", "Falcon"});
  ASSERT_EQ(timeouts.size(), 2u);
  EXPECT_EQ(timeouts[0].setting, "High Fidelity");  // protocol order
  EXPECT_EQ(timeouts[1].trials, 41 * 16);
  EXPECT_EQ(timeouts[1].timed_out, 4);
  EXPECT_DOUBLE_EQ(timeouts[1].rate, 4.0 / (41 * 16));
  EXPECT_GT(timeouts[1].wilson_low, 0.0);
}

ReportVariant report_variant(const std::string& label, double change, double low, double high, double power,
                      double power_low, double power_high) {
  ReportVariant v;
  v.label = label;
  v.changes.push_back({8, "clip", "Falcon", "force_p95_N", 200, change, low, high});
  PowerRow p;
  p.participants = 8;
  p.method = "participant_pairwise";
  p.task = "clip";
  p.setting = "Falcon";
  p.measure = "force_p95_N";
  p.tests = 200;
  p.significant = static_cast<int>(200 * power);
  p.rate = power;
  p.wilson_low = power_low;
  p.wilson_high = power_high;
  v.power.push_back(p);
  p.method = "pairwise";
  p.rate = 0.99;
  v.power.push_back(p);
  v.timeouts.push_back({8, "clip", "Falcon", 1600, 16, 0.01, 0.006, 0.016});
  return v;
}

// A fitted population's uncertainty is a second variant, whose columns
// sit beside the first's, its power cells with the model interval. Every table says whose predictions
// these are.
TEST(ComparisonReportTest, TheTablesSayTheyAreTheModelsAndTakeASecondVariantBeside) {
  ComparisonReportOptions o;
  o.control = "High Fidelity";
  o.participants = {8};
  o.settings = {"High Fidelity", "Falcon"};
  const ReportVariant fixed = report_variant("model fixed", 0.35, 0.25, 0.45, 0.88, 0.83, 0.93);
  ReportVariant uncertain = report_variant("with model uncertainty", 0.3, 0.2, 0.4, 0.7, 0.65, 0.75);
  // Studies drawn from a fit's posterior carry the interval with the
  // model's uncertainty (power.h) beside Wilson's.
  uncertain.power.front().model_low = 0.52;
  uncertain.power.front().model_high = 0.86;
  const std::string one = comparison_markdown({fixed}, o);
  EXPECT_THAT(one, HasSubstr("**These are the model's predictions**"));
  EXPECT_THAT(one, HasSubstr("| measure | setting | 8 participants: predicted change | 8 participants: power |"));
  EXPECT_THAT(one, HasSubstr("| force_p95_N | Falcon | +35 % [+25, +45] | 88 % [83, 93] |"));
  EXPECT_THAT(one, HasSubstr("Trials that timed out, left out of the change and the power (8 participants): "
                             "Falcon 1 % [1, 2] of 1600."));
  EXPECT_THAT(one, Not(HasSubstr("model fixed:")));  // one variant: no variant in the headings
  const std::string two = comparison_markdown({fixed, uncertain}, o);
  EXPECT_THAT(two, HasSubstr("| 8 participants, model fixed: predicted change | 8 participants, model fixed: power | "
                             "8 participants, with model uncertainty: predicted change | 8 participants, with model "
                             "uncertainty: power |"));
  EXPECT_THAT(two, HasSubstr("| force_p95_N | Falcon | +35 % [+25, +45] | 88 % [83, 93] | +30 % [+20, +40] | "
                             "70 % [65, 75] model [52, 86] |"));
  EXPECT_THAT(two, HasSubstr("\"model [ ]\" is the 95 % interval with the model's uncertainty added"));
  // The thesis procedure's power when asked for.
  o.method = "pairwise";
  EXPECT_THAT(comparison_markdown({fixed}, o), HasSubstr("| +35 % [+25, +45] | 99 % ["));
  const std::string csv = comparison_csv({fixed, uncertain}, o);
  EXPECT_THAT(csv, HasSubstr("variant,participants,task,setting,measure,studies,predicted_change_median,"));
  EXPECT_THAT(csv, HasSubstr("\nmodel fixed,8,clip,Falcon,force_p95_N,200,0.35,0.25,0.45,0.88,0.83,0.93,0.99,"));
  EXPECT_THAT(csv, HasSubstr(",trials_run,trials_timed_out,participant_power_model_low,participant_power_model_high\n"));
  EXPECT_THAT(csv, HasSubstr(",1600,16,,\nwith model uncertainty,8,clip,Falcon,force_p95_N,200,0.3,"));
  EXPECT_THAT(csv, HasSubstr(",0.7,0.65,0.75,0.99,"));
  EXPECT_THAT(csv, HasSubstr(",1600,16,0.52,0.86\n"));
}

}  // namespace
}  // namespace hapticlab::planning
