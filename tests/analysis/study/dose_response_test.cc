#include "analysis/study/dose_response.h"

#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "analysis/stats/data_error.h"
#include "analysis/study/participant_level.h"
#include "core/settings/settings_json.h"

namespace hapticlab::analysis {
namespace {

const std::vector<double> kStrengths = {0.1, 0.2, 0.45, 0.9};
const std::string kControl = "High Fidelity";

std::string dose_name(double strength) {
  return dose_setting_name("Insertion friction", "translation.friction.dynamic_level_N", strength);
}

// The study's series as analyze_study builds it: the control at 0 (friction off), then each strength.
DoseSeries friction_series() {
  DoseSeries d;
  d.field = "translation.friction.dynamic_level_N";
  d.levels.push_back({kControl, 0.0});
  for (double s : kStrengths) d.levels.push_back({dose_name(s), s});
  return d;
}

TrialRecord dose_trial(const std::string& participant, const std::string& setting, double p95_N) {
  TrialRecord t;
  t.participant = participant;
  t.task = "clip";
  t.setting = setting;
  t.window = TaskWindow{0.0, 10.0};
  for (HandMetrics& h : t.hands) {
    h.force_median_N = h.speed_median_m_per_s = h.path_length_m = std::nan("");
    h.force_p95_N = p95_N;
  }
  return t;
}

// Six participants, base 2 + i N, plus `response(level index, participant)`
// at each level, two repetitions alike. Statistics as run_statistics would.
StudyAnalysis dose_study(double (*response)(std::size_t level, std::size_t participant)) {
  StudyAnalysis a;
  a.tasks = {"clip"};
  a.dose = friction_series();
  for (const DoseLevel& l : a.dose->levels) a.settings.push_back(l.setting);
  a.control = kControl;
  a.options.alpha = 0.05;
  a.sidak_level = 0.05;
  for (std::size_t p = 0; p < 6; ++p) {
    const std::string code = "P" + std::to_string(p + 1);
    a.participants.push_back(code);
    for (std::size_t l = 0; l < a.dose->levels.size(); ++l)
      for (int rep = 0; rep < 2; ++rep)
        a.trials.push_back(dose_trial(code, a.dose->levels[l].setting, 2.0 + static_cast<double>(p) + response(l, p)));
  }
  a.participant_pairwise = participant_pairwise(a);
  return a;
}

const DoseResponseRow& p95_row(const StudyAnalysis& a, const std::vector<DoseResponseRow>& rows) {
  for (const DoseResponseRow& r : rows)
    if (r.measure == Measure::kForceP95) return r;
  ADD_FAILURE() << "no 95p force row in " << a.study_name;
  return rows.front();
}

// y = base + k x with k = 1..6 N per N: each slope is k exactly, their mean
// 3.5; all six positive, so the sign-flip p is 2 / 2^6 = 0.03125, and so is
// every strength's against the control: the fixed sequence reaches 0.1.
TEST(DoseResponseTest, LinearResponsesGiveTheirSlopesAndTheSmallestStrength) {
  const StudyAnalysis a = dose_study([](std::size_t l, std::size_t p) {
    return static_cast<double>(p + 1) * (l == 0 ? 0.0 : kStrengths[l - 1]);
  });
  const std::vector<DoseResponseRow> rows = dose_response(a);
  ASSERT_EQ(rows.size(), kAllMeasures.size());
  const DoseResponseRow& r = p95_row(a, rows);
  ASSERT_EQ(r.participants.size(), 6u);
  for (std::size_t p = 0; p < 6; ++p) {
    ASSERT_TRUE(r.participants[p].slope.has_value());
    EXPECT_NEAR(*r.participants[p].slope, static_cast<double>(p + 1), 1e-12);
    EXPECT_NEAR(r.participants[p].medians[4], 2.0 + p + 0.9 * (p + 1), 1e-12);
  }
  ASSERT_TRUE(r.trend_p.has_value());
  EXPECT_DOUBLE_EQ(*r.trend_p, 0.03125);
  EXPECT_NEAR(r.mean_slope, 3.5, 1e-12);
  EXPECT_EQ(r.slopes, 6u);
  EXPECT_TRUE(r.trend_significant);
  // The level medians: the median over participants of 2 + p + k x (p = 0..5, k = p + 1) at x = 0.45:
  // the values 2.45, 3.9, 5.35, 6.8, 8.25, 9.7; the median (matlab) 6.075.
  EXPECT_NEAR(r.level_medians[3], 6.075, 1e-12);
  ASSERT_TRUE(r.smallest_significant_strength.has_value());
  EXPECT_DOUBLE_EQ(*r.smallest_significant_strength, 0.1);
  // A measure without data: no slope, said so.
  for (const DoseResponseRow& none : rows)
    if (none.measure == Measure::kPathLength) {
      EXPECT_FALSE(none.trend_p.has_value());
      EXPECT_EQ(none.note, "no participant has data at two strengths");
    }
}

// A threshold at 0.45 N: below it the differences alternate in sign (+-0.05,
// sum 0: p = 1), from it on every participant is 1 N higher (p = 0.03125).
TEST(DoseResponseTest, AThresholdResponseFindsTheThreshold) {
  const StudyAnalysis a = dose_study([](std::size_t l, std::size_t p) {
    if (l >= 3) return 1.0;
    return l == 0 ? 0.0 : (p % 2 == 0 ? 0.05 : -0.05);
  });
  const std::vector<DoseResponseRow> rows = dose_response(a);
  const DoseResponseRow& r = p95_row(a, rows);
  ASSERT_TRUE(r.p_vs_control[1].has_value());
  EXPECT_DOUBLE_EQ(*r.p_vs_control[1], 1.0);
  EXPECT_DOUBLE_EQ(*r.p_vs_control[3], 0.03125);
  ASSERT_TRUE(r.smallest_significant_strength.has_value());
  EXPECT_DOUBLE_EQ(*r.smallest_significant_strength, 0.45);
  EXPECT_GT(r.mean_slope, 0.0);
}

// The fixed sequence stops at the first strength that is not significant:
// here the strongest, so 0.45's own p of 0.03125 does not count.
TEST(DoseResponseTest, TheFixedSequenceStopsAtTheStrongestWhenItIsNotSignificant) {
  const StudyAnalysis a = dose_study([](std::size_t l, std::size_t p) {
    if (l == 4) return p % 2 == 0 ? 0.05 : -0.05;
    return l == 3 ? 1.0 : 0.0;
  });
  const std::vector<DoseResponseRow> rows = dose_response(a);
  const DoseResponseRow& r = p95_row(a, rows);
  EXPECT_DOUBLE_EQ(*r.p_vs_control[3], 0.03125);
  EXPECT_DOUBLE_EQ(*r.p_vs_control[4], 1.0);
  EXPECT_FALSE(r.smallest_significant_strength.has_value());
}

std::string stored(const std::string& settings_json_text) {
  return settings_to_json(settings_from_json_text(settings_json_text, "test")).dump();
}

std::string friction_at(double strength) {
  return stored(R"({"name": ")" + dose_name(strength) +
                R"(", "translation": {"friction": {"enabled": true, "dynamic_level_N": )" + std::to_string(strength) +
                "}}}");
}

const std::string kDoseProtocol = R"({"study": "s", "dose": {"settings": "x.json",
  "field": "translation.friction.dynamic_level_N", "strengths": [0.1, 0.2, 0.45, 0.9]}})";

// The series comes from the protocol text the study stored and the settings'
// stored parameters; a strength without trials is left out.
TEST(DoseResponseTest, TheSeriesIsFoundFromTheStoredProtocolAndSettings) {
  const std::vector<std::pair<std::string, std::string>> settings = {
      {kControl, stored(R"({"name": "High Fidelity"})")},
      {dose_name(0.1), friction_at(0.1)},
      {dose_name(0.9), friction_at(0.9)},
      {"Cogging", stored(R"({"name": "Cogging"})")}};
  const std::optional<DoseSeries> d = find_dose_series(kDoseProtocol, kControl, settings);
  ASSERT_TRUE(d.has_value());
  EXPECT_EQ(d->field, "translation.friction.dynamic_level_N");
  ASSERT_EQ(d->levels.size(), 3u);
  EXPECT_EQ(d->levels[0].setting, kControl);
  EXPECT_DOUBLE_EQ(d->levels[0].strength, 0.0);  // friction off
  EXPECT_EQ(d->levels[1].setting, "Insertion friction, dynamic_level_N = 0.1");
  EXPECT_DOUBLE_EQ(d->levels[2].strength, 0.9);
  // No "dose": no series.
  EXPECT_FALSE(find_dose_series(R"({"study": "s"})", kControl, settings).has_value());
}

TEST(DoseResponseTest, ASettingNamedAsAStrengthButHoldingAnotherValueIsNamed) {
  const std::vector<std::pair<std::string, std::string>> settings = {
      {kControl, stored(R"({"name": "High Fidelity"})")}, {dose_name(0.45), friction_at(0.2)}};
  try {
    find_dose_series(kDoseProtocol, kControl, settings);
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_EQ(std::string(e.what()),
                      "setting 'Insertion friction, dynamic_level_N = 0.45' is named as the dose strength 0.45, but "
                      "its translation.friction.dynamic_level_N is 0.2");
  }
}

}  // namespace
}  // namespace hapticlab::analysis
