#include "analysis/study/participant_level.h"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

namespace hapticlab::analysis {
namespace {

TrialRecord trial(const std::string& participant, const std::string& setting, double left_N, double right_N) {
  TrialRecord t;
  t.participant = participant;
  t.task = "clip";
  t.setting = setting;
  t.window = TaskWindow{0.0, 10.0};
  for (HandMetrics& h : t.hands) h.force_median_N = h.speed_median_m_per_s = h.path_length_m = std::nan("");
  t.hands[0].force_p95_N = left_N;
  t.hands[1].force_p95_N = right_N;
  return t;
}

// By hand. Each participant's value per setting is the median over
// repetitions and hands: A: control {1, 1, 2, 2} -> 1.5, X {3, 3, 2, 2} ->
// 2.5, d = 1; B: control {1, 1} -> 1, X {3, 3} -> 3, d = 2; C: control
// {1, 1} -> 1, X {4, 4} -> 4, d = 3; D did only the control (left out).
// Sign flips of {1, 2, 3}: p = 2/8 = 0.25; mean difference 2 N.
TEST(ParticipantPairwiseTest, OneValuePerParticipantThenTheSignFlipTest) {
  StudyAnalysis a;
  a.tasks = {"clip"};
  a.settings = {"High Fidelity", "X"};
  a.control = "High Fidelity";
  a.sidak_level = 0.05;
  a.trials = {trial("A", "High Fidelity", 1, 1), trial("A", "High Fidelity", 2, 2), trial("A", "X", 3, 3),
              trial("A", "X", 2, 2),             trial("B", "High Fidelity", 1, 1), trial("B", "X", 3, 3),
              trial("C", "High Fidelity", 1, 1), trial("C", "X", 4, 4),             trial("D", "High Fidelity", 9, 9)};
  const std::vector<ParticipantPairwiseCell> cells = participant_pairwise(a);
  const auto it = std::find_if(cells.begin(), cells.end(), [](const auto& c) { return c.measure == Measure::kForceP95; });
  ASSERT_NE(it, cells.end());
  EXPECT_EQ(it->setting, "X");
  EXPECT_EQ(it->participants, 3u);
  ASSERT_TRUE(it->p.has_value());
  EXPECT_DOUBLE_EQ(*it->p, 0.25);
  ASSERT_TRUE(it->mean_difference.has_value());
  EXPECT_DOUBLE_EQ(*it->mean_difference, 2.0);
  EXPECT_FALSE(it->significant);  // 3 participants can never reach p < 0.25
  // Measures without data (NaN everywhere else): no test, and said so.
  const auto none = std::find_if(cells.begin(), cells.end(), [](const auto& c) { return c.measure == Measure::kPathLength; });
  ASSERT_NE(none, cells.end());
  EXPECT_FALSE(none->p.has_value());
  EXPECT_EQ(none->note, "no participant has data for both settings");
}

}  // namespace
}  // namespace hapticlab::analysis
