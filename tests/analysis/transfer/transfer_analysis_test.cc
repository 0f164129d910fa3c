#include "analysis/transfer/transfer_analysis.h"

#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/io/long_csv.h"
#include "analysis/stats/data_error.h"

namespace hapticlab::analysis::transfer {
namespace {

using ::testing::HasSubstr;
using learning::TrialColumns;

// Control trains on nothing; "lofi" trains 10 trials on the cheap device.
// Criterion 30 s (lower is better). Post-test trials to criterion:
//   control C1 40 35 28 -> 3, C2 32 29 -> 2, C3 45 40 31 29 -> 4, C4 29 -> 1: Yc = 2.5
//   lofi    L1 29 -> 1, L2 31 28 -> 2, L3 25 -> 1, L4 27 -> 1:             Yx = 1.25
// TER = (2.5 - 1.25) / 10 = 0.125.
std::string table_text(bool with_control_training = false) {
  std::ostringstream csv;
  csv << "participant,group,phase,trial,completion_time_s\n";
  const char* control_post[] = {"40 35 28", "32 29", "45 40 31 29", "29"};
  const char* lofi_post[] = {"29", "31 28", "25", "27"};
  for (int p = 0; p < 4; ++p) {
    for (int g = 0; g < 2; ++g) {
      const std::string id = std::string(g == 0 ? "C" : "L") + std::to_string(p + 1);
      const std::string group = g == 0 ? "control" : "lofi";
      csv << id << ',' << group << ",pre,1," << 50 + p << '\n';
      if (g == 1 || with_control_training)
        for (int t = 1; t <= 10; ++t) csv << id << ',' << group << ",training," << t << ',' << 45 - t << '\n';
      std::istringstream post(g == 0 ? control_post[p] : lofi_post[p]);
      double v;
      for (int t = 1; post >> v; ++t) csv << id << ',' << group << ",post," << t << ',' << v << '\n';
      if (p < 3) csv << id << ',' << group << ",retention,1," << 33 + p << '\n';
    }
  }
  return csv.str();
}

learning::TrialTable table(const std::string& text, const std::string& measure = "completion_time_s") {
  TrialColumns columns;
  columns.measure = measure;
  return learning::read_trial_table(LongCsv::parse(text, "trials.csv"), columns);
}

TEST(TransferAnalysis, ComparesChangesAndComputesTer) {
  TransferOptions options;
  options.control_group = "control";
  options.criterion = 30.0;
  const auto a = analyze_transfer(table(table_text()), options);
  ASSERT_EQ(a.comparisons.size(), 2u);
  const auto& post = a.comparisons[0];
  EXPECT_EQ(post.outcome, "post-pre");
  ASSERT_TRUE(post.test);
  EXPECT_TRUE(post.test->exact);
  EXPECT_DOUBLE_EQ(post.test->assignments, 70.0);  // C(8, 4)
  // Changes post - pre (medians): control -15, -20.5, -16.5, -24; lofi -21,
  // -21.5, -27, -26: lofi improved more; the 16 differences lofi - control
  // sorted: -12 -11 -10.5 -9.5 -6.5 -6.5 -6 -5.5 | -5 -4.5 -3 -2 -1 -0.5
  // 2.5 3, median -5.25.
  ASSERT_EQ(post.shifts.size(), 1u);
  EXPECT_EQ(post.shifts[0].group, "lofi");
  EXPECT_DOUBLE_EQ(post.shifts[0].shift.shift, -5.25);
  const auto& retention = a.comparisons[1];
  EXPECT_EQ(retention.outcome, "retention-pre");
  EXPECT_EQ(retention.excluded, (std::vector<std::string>{"C4", "L4"}));
  ASSERT_EQ(a.transfer.size(), 1u);
  ASSERT_TRUE(a.transfer[0].ratio) << a.transfer[0].refusal;
  EXPECT_DOUBLE_EQ(a.transfer[0].ratio->ter, 0.125);
  std::ostringstream text;
  write_transfer_text(a, text);
  EXPECT_THAT(text.str(), HasSubstr("TER = 0.125 (Yc = 2.5, Yx = 1.25, X = 10 trials)"));
  EXPECT_THAT(text.str(), HasSubstr("(exact, 70 assignments)"));

  // Criterion never reached by some: TER refused by name, not guessed.
  options.criterion = 26.0;
  const auto strict = analyze_transfer(table(table_text()), options);
  EXPECT_FALSE(strict.transfer[0].ratio);
  EXPECT_THAT(strict.transfer[0].refusal, HasSubstr("criterion not reached in the post-test by: C1 C2 C3 C4 (control) L1 L2 L4 (lofi)"));
}

TEST(TransferAnalysis, RefusesByName) {
  TransferOptions none;
  EXPECT_THAT(analyze_transfer(table(table_text()), none).transfer_refusal, HasSubstr("no control group declared"));
  auto message = [](const std::string& text, const TransferOptions& options, const std::string& measure = "completion_time_s") {
    try {
      analyze_transfer(table(text, measure), options);
    } catch (const DataError& e) {
      return std::string(e.what());
    }
    return std::string("no refusal");
  };
  TransferOptions absent;
  absent.control_group = "nosim";
  EXPECT_THAT(message(table_text(), absent), HasSubstr("control group 'nosim' has no participants"));
  TransferOptions control;
  control.control_group = "control";
  control.criterion = 30.0;
  EXPECT_THAT(message(table_text(true), control),
              HasSubstr("control group 'control' participant C1 has 10 training trials (allowed: 0"));
  EXPECT_THAT(message(table_text(), control, "force_p95_N"), HasSubstr("force_p95_N"));
  std::string no_pre = table_text();
  no_pre.erase(no_pre.find("C1,control,pre,1,50\n"), std::string("C1,control,pre,1,50\n").size());
  EXPECT_THAT(message(no_pre, control), HasSubstr("participant C1 has no pre-test trial"));
  std::string nan = table_text();
  nan.replace(nan.find("C1,control,pre,1,50"), 19, "C1,control,pre,1,nan");
  EXPECT_THAT(message(nan, control), HasSubstr("nan"));
  std::string phase = table_text();
  phase.replace(phase.find("C1,control,pre"), 14, "C1,control,mid");
  EXPECT_THAT(message(phase, control), HasSubstr("phase 'mid' (allowed: pre, training, post, retention)"));
  std::string twice = table_text();
  twice += "C1,control,post,1,20\n";
  EXPECT_THAT(message(twice, control), HasSubstr("participant C1 has trial 1 twice in phase post"));
  std::string moved = table_text() + "C1,lofi,post,9,20\n";
  EXPECT_THAT(message(moved, control), HasSubstr("participant C1 is in group 'lofi' here and in 'control' earlier"));
  std::string fraction = table_text() + "C1,control,post,2.5,20\n";
  EXPECT_THAT(message(fraction, control), HasSubstr("trial index 2.5 (allowed: an integer >= 1)"));
  std::string one_group = "participant,group,phase,trial,completion_time_s\nA,g,pre,1,3\nA,g,post,1,2\n";
  EXPECT_THAT(message(one_group, none), HasSubstr("1 group(s) with participants (allowed: at least 2)"));
}

}  // namespace
}  // namespace hapticlab::analysis::transfer
