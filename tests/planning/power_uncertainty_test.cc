// Power with the model's uncertainty (planning/power.h summarize_power with
// draw groups), on outcomes set by hand: groups whose power differs widen
// the interval beyond the simulation-only one; groups that agree leave it
// at the sampling interval.
#include <gtest/gtest.h>

#include "planning/power.h"

namespace hapticlab::planning {
namespace {

// `studies` outcomes; study i is significant when significant(i).
template <typename F>
std::vector<StudyOutcome> outcomes(int studies, F significant) {
  std::vector<StudyOutcome> out;
  for (int i = 0; i < studies; ++i) {
    StudyOutcome o;
    o.participants = 3;
    o.index = i;
    Finding f;
    f.method = "pairwise";
    f.task = "clip";
    f.setting = "NFF";
    f.measure = "force_p95_N";
    f.p = 0.001;
    f.significant = significant(i);
    o.findings.push_back(f);
    out.push_back(o);
  }
  return out;
}

TEST(PowerUncertaintyTest, GroupsThatDisagreeWidenTheIntervalAndGroupsThatAgreeDoNot) {
  // 400 studies, 20 per draw group. Half the groups always significant,
  // half never: the power is 50 %, but 0 or 1 depending on the model; the
  // between-group variance is 0.25, so the interval spans about 0..1.
  const auto split = outcomes(400, [](int i) { return draw_group(i) < kDrawGroups / 2; });
  const PowerRow a = summarize_power(split, {"HF", "NFF"}, kDrawGroups).at(0);
  EXPECT_DOUBLE_EQ(a.rate, 0.5);
  EXPECT_LT(a.wilson_high - a.wilson_low, 0.11);  // sampling of 400 studies: +-5 points
  EXPECT_LT(a.model_low, 0.05);
  EXPECT_GT(a.model_high, 0.95);
  // Every group at 50 % (every other study): no model uncertainty beyond
  // sampling; the interval stays the sampling one (normal approximation).
  const auto even = outcomes(400, [](int i) { return (i / kDrawGroups) % 2 == 0; });
  const PowerRow b = summarize_power(even, {"HF", "NFF"}, kDrawGroups).at(0);
  EXPECT_DOUBLE_EQ(b.rate, 0.5);
  EXPECT_NEAR(b.model_low, 0.5 - 1.96 * 0.025, 1e-9);
  EXPECT_NEAR(b.model_high, 0.5 + 1.96 * 0.025, 1e-9);
  // Without draw groups: no model interval.
  const PowerRow c = summarize_power(split, {"HF", "NFF"}).at(0);
  EXPECT_TRUE(std::isnan(c.model_low));
  // Draws are spread over the posterior's draws.
  EXPECT_EQ(draw_of_group(0, 200), 0u);
  EXPECT_EQ(draw_of_group(19, 200), 190u);
  EXPECT_EQ(draw_of_group(5, 3), 0u);
}

}  // namespace
}  // namespace hapticlab::planning
