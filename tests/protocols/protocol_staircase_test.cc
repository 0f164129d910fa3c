// Staircase protocols (issue 19 §4 and §5): the "staircase" block read into
// its rule and base settings, a schedule of the baseline alone, and every
// bad block named by its field — a staircase without a baseline first.
#include <filesystem>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "protocols/protocol_json.h"
#include "protocols/schedule.h"
#include "tests/protocols/protocol_failure.h"

namespace hapticlab::protocols {
namespace {

using ::testing::HasSubstr;
using nlohmann::json;

json staircase_protocol() {
  return json::parse(R"({
    "study": "staircase",
    "tasks": ["clip"],
    "repetitions": {"clip": 3},
    "settings": ["../settings/high_fidelity.json"],
    "staircase": {"settings": {"name": "Insertion friction", "translation": {"friction": {}}},
                  "field": "translation.friction.dynamic_level_N", "measure": "force_p95_N", "change": 0.2,
                  "baseline": "High Fidelity", "start": 0.9, "step": 0.2, "min": 0, "max": 2},
    "participants": ["P1", "P2"],
    "design": {"type": "complete"},
    "seed": 3
  })");
}

TEST(ProtocolStaircaseTest, TheBlockIsReadWithItsDefaultsAndTheBaselineAloneIsScheduled) {
  const Protocol p = protocol_from_json(staircase_protocol(), testing::kExampleProtocolsDir, "s.json");
  ASSERT_TRUE(p.staircase.has_value());
  const StaircaseSpec& s = p.staircase->spec;
  EXPECT_EQ(s.task, "clip");  // the only task
  EXPECT_EQ(s.direction, ChangeDirection::kEither);
  EXPECT_EQ(s.down, 1);
  EXPECT_EQ(s.reversals, 8);
  EXPECT_EQ(s.max_trials, 30);
  EXPECT_EQ(p.staircase->base.settings.name, "Insertion friction");
  // One setting is enough with a staircase: three baseline trials each.
  const StudyPlan plan = make_study_plan(p);
  ASSERT_EQ(plan.participants.size(), 2u);
  EXPECT_EQ(plan.participants[0].trials.size(), 3u);
  for (const PlannedTrial& t : plan.participants[0].trials) EXPECT_EQ(t.setting, "High Fidelity");
  // The stored text gives the same rule without the protocol's files.
  const auto stored = staircase_from_protocol_text(staircase_protocol().dump(), "stored");
  ASSERT_TRUE(stored.has_value());
  EXPECT_EQ(stored->task, "clip");
  EXPECT_EQ(stored->baseline, "High Fidelity");
  EXPECT_EQ(stored->max, 2.0);
  EXPECT_FALSE(staircase_from_protocol_text(R"({"study": "x"})", "stored").has_value());
}

TEST(ProtocolStaircaseTest, AStaircaseWithoutABaselineIsNamed) {
  json j = staircase_protocol();
  j["staircase"].erase("baseline");
  auto f = testing::protocol_failure(j, testing::kExampleProtocolsDir);
  EXPECT_EQ(f.field, "staircase.baseline");
  EXPECT_THAT(f.message, HasSubstr("is missing, but a staircase needs a baseline"));

  j = staircase_protocol();
  j["staircase"]["baseline"] = "Cogging";
  f = testing::protocol_failure(j, testing::kExampleProtocolsDir);
  EXPECT_EQ(f.field, "staircase.baseline");
  EXPECT_THAT(f.message, HasSubstr("is \"Cogging\", but is not one of the settings (\"High Fidelity\")"));

  // In an incomplete design, a baseline some participants would not do.
  j = staircase_protocol();
  j["settings"] = {"../settings/high_fidelity.json", "../settings/cogging.json", "../settings/no_force_feedback.json"};
  j["design"] = {{"type", "incomplete"}, {"required", {"Cogging"}}, {"k", 1}};
  f = testing::protocol_failure(j, testing::kExampleProtocolsDir);
  EXPECT_EQ(f.field, "staircase.baseline");
  EXPECT_THAT(f.message, HasSubstr("is not in design.required"));
}

TEST(ProtocolStaircaseTest, BadRulesAreNamed) {
  struct Case {
    const char* key;
    json value;
    const char* field;
    const char* says;
  };
  const Case cases[] = {
      {"measure", "force_max_N", "staircase.measure", "must be one of force_median_N, force_p95_N"},
      {"change", 0, "staircase.change", "must be a number > 0 and <= 10"},
      {"direction", "up", "staircase.direction", "must be \"increase\", \"decrease\" or \"either\""},
      {"start", 3, "staircase.start", "must be a number >= 0 and <= 2"},
      {"step", 0, "staircase.step", "must be a number > 0 and <= 2"},
      {"max", -1, "staircase.max", "must be greater than staircase.min"},
      {"max", 1e9, "staircase.max", "is not a valid translation.friction.dynamic_level_N"},
      {"reversals", 7, "staircase.reversals", "must be even"},
      {"down", 4, "staircase.down", "4"},
      {"max_trials", 8, "staircase.max_trials", "must be greater than staircase.reversals (8)"},
      {"field", "translation.friction.enabled", "staircase.field", "must be a numeric settings field"},
      {"task", "dissection", "staircase.task", "is not one of the protocol's tasks"},
  };
  for (const Case& c : cases) {
    json j = staircase_protocol();
    j["staircase"][c.key] = c.value;
    const auto f = testing::protocol_failure(j, testing::kExampleProtocolsDir);
    EXPECT_EQ(f.field, c.field) << c.key << " = " << c.value << ": " << f.message;
    EXPECT_THAT(f.message, HasSubstr(c.says)) << c.key;
  }
  json both = staircase_protocol();
  both["dose"] = {{"settings", "../settings/cogging.json"}, {"field", "translation.cogging.amplitude_N"},
                  {"strengths", {0.1, 0.2}}};
  EXPECT_EQ(testing::protocol_failure(both, testing::kExampleProtocolsDir).field, "staircase");
}

}  // namespace
}  // namespace hapticlab::protocols
