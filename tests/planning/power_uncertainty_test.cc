// Power with the model's uncertainty (planning/power.h summarize_power with
// draw groups), on outcomes set by hand: groups whose power differs widen
// the interval beyond the simulation-only one; groups that agree leave it
// at the sampling interval.
#include <gtest/gtest.h>

#include <cmath>

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
  // sampling; the interval stays the sampling one, Wilson's.
  const auto even = outcomes(400, [](int i) { return (i / kDrawGroups) % 2 == 0; });
  const PowerRow b = summarize_power(even, {"HF", "NFF"}, kDrawGroups).at(0);
  EXPECT_DOUBLE_EQ(b.rate, 0.5);
  // Wilson at 200/400: 0.5 -+ z sqrt(0.25/n + z^2/(4 n^2)) / (1 + z^2/n).
  const double z = 1.959963984540054, n = 400;  // the 97.5 % normal quantile
  EXPECT_NEAR(b.model_low, 0.5 - z * std::sqrt(0.25 / n + z * z / (4 * n * n)) / (1 + z * z / n), 1e-9);
  EXPECT_DOUBLE_EQ(b.model_low, b.wilson_low);
  EXPECT_DOUBLE_EQ(b.model_high, b.wilson_high);
  // Every study significant (or none): the groups agree, the sampling
  // interval is Wilson's [0.9905, 1] (1 - z^2/(n + z^2)),
  // and the model interval is that one, not the normal approximation's
  // [1, 1] of no width.
  for (const bool all : {true, false}) {
    const PowerRow d = summarize_power(outcomes(400, [all](int) { return all; }), {"HF", "NFF"}, kDrawGroups).at(0);
    EXPECT_NEAR(all ? 1 - d.wilson_low : d.wilson_high, z * z / (n + z * z), 1e-9);
    EXPECT_DOUBLE_EQ(d.model_low, d.wilson_low);
    EXPECT_DOUBLE_EQ(d.model_high, d.wilson_high);
  }
  // Groups that disagree only a little: never narrower than Wilson on
  // either side.
  const auto few = outcomes(400, [](int i) { return draw_group(i) == 0 && i % 2 == 0; });
  const PowerRow e = summarize_power(few, {"HF", "NFF"}, kDrawGroups).at(0);
  EXPECT_LE(e.model_low, e.wilson_low);
  EXPECT_GE(e.model_high, e.wilson_high);
  EXPECT_GT(e.model_high - e.model_low, e.wilson_high - e.wilson_low);
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
