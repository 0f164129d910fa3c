// Dose-response protocols (issue 19 §4): one degradation at several
// strengths, each a setting of its own, and a bad dose named by its field.
#include <filesystem>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "protocols/protocol_error.h"
#include "protocols/protocol_json.h"
#include "protocols/schedule.h"
#include "tests/protocols/protocol_failure.h"

namespace hapticlab::protocols {
namespace {

using ::testing::HasSubstr;
using nlohmann::json;

json dose_protocol() {
  return json::parse(R"({
    "study": "dose",
    "tasks": ["clip"],
    "repetitions": {"clip": 2},
    "settings": ["../settings/high_fidelity.json"],
    "dose": {"settings": "../settings/cogging.json", "field": "translation.cogging.amplitude_N",
             "strengths": [0.15, 0.3, 0.6]},
    "participants": ["P1", "P2"],
    "design": {"type": "complete"},
    "seed": 3
  })");
}

std::pair<std::string, std::string> dose_failure(const json& j) {
  const testing::Failure f = testing::protocol_failure(j, testing::kExampleProtocolsDir, "dose.json");
  return {f.field, f.message};
}

TEST(ProtocolDoseTest, EachStrengthIsASettingOfItsOwnWithOnlyTheFieldChanged) {
  const Protocol p = protocol_from_json(dose_protocol(), testing::kExampleProtocolsDir, "dose.json");
  ASSERT_EQ(p.settings.size(), 4u);
  EXPECT_EQ(p.settings[0].settings.name, "High Fidelity");
  const double strengths[] = {0.15, 0.3, 0.6};
  for (int i = 0; i < 3; ++i) {
    const ProtocolSetting& s = p.settings[1 + i];
    EXPECT_EQ(s.settings.name, "Cogging, amplitude_N = " + json(strengths[i]).dump());
    EXPECT_EQ(s.source, "../settings/cogging.json, translation.cogging.amplitude_N = " + json(strengths[i]).dump());
    EXPECT_TRUE(s.settings.engine.translation.cogging.enabled);
    EXPECT_EQ(s.settings.engine.translation.cogging.amplitude, strengths[i]);
    // Everything else is the base file's.
    json got = settings_to_json(s.settings), base = settings_to_json(load_settings_file(testing::kExampleProtocolsDir / "../settings/cogging.json"));
    got.erase("name");
    base.erase("name");
    got["translation"]["cogging"].erase("amplitude_N");
    base["translation"]["cogging"].erase("amplitude_N");
    EXPECT_EQ(got, base);
  }
  // The schedule block-randomizes the strengths like settings: each of the
  // 4 settings twice per participant.
  for (const auto& pp : make_study_plan(p).participants) EXPECT_EQ(pp.trials.size(), 8u);
}

TEST(ProtocolDoseTest, TheShippedFrictionDoseProtocolPlans) {
  const Protocol p = load_protocol_file(testing::kExampleProtocolsDir / "friction_dose.json");
  ASSERT_EQ(p.settings.size(), 5u);
  EXPECT_EQ(p.settings[4].settings.name, "Insertion friction, dynamic_level_N = 0.9");
  EXPECT_EQ(p.settings[4].settings.engine.translation.friction.dynamic_level, 0.9);
  EXPECT_FALSE(p.settings[4].settings.engine.rotation.friction.enabled);
}

TEST(ProtocolDoseTest, ADoseListThatIsNotIncreasingIsNamed) {
  json j = dose_protocol();
  j["dose"]["strengths"] = {0.15, 0.6, 0.3};
  auto [field, message] = dose_failure(j);
  EXPECT_EQ(field, "dose.strengths[2]");
  EXPECT_THAT(message, HasSubstr("is 0.3, but must be greater than dose.strengths[1] (0.6): strengths are listed "
                                 "in increasing order, each once"));
  j["dose"]["strengths"] = {0.15, 0.15};
  std::tie(field, message) = dose_failure(j);
  EXPECT_EQ(field, "dose.strengths[1]");
}

TEST(ProtocolDoseTest, BadDosesAreNamedByTheirField) {
  json j = dose_protocol();
  j["dose"]["field"] = "translation.cogging.amplitude";
  EXPECT_EQ(dose_failure(j).first, "dose.field");
  EXPECT_THAT(dose_failure(j).second, HasSubstr("must be a numeric settings field"));
  j["dose"]["field"] = "translation.viscosity.amplitude_N";  // a block that does not exist
  EXPECT_EQ(dose_failure(j).first, "dose.field");
  j["dose"]["field"] = "translation";  // a block, not a number
  EXPECT_EQ(dose_failure(j).first, "dose.field");
  j = dose_protocol();
  j["dose"]["strengths"] = {0.3};
  EXPECT_EQ(dose_failure(j).first, "dose.strengths");
  j = dose_protocol();
  j["dose"]["strengths"] = {0.3, "lots"};
  EXPECT_EQ(dose_failure(j).first, "dose.strengths[1]");
  j = dose_protocol();
  j["dose"]["strengths"] = {0.3, 60.0};  // beyond the field's range
  auto [field, message] = dose_failure(j);
  EXPECT_EQ(field, "dose.strengths[1]");
  EXPECT_THAT(message, HasSubstr("translation.cogging.amplitude_N"));
  j = dose_protocol();
  j["dose"]["steps"] = 3;
  EXPECT_EQ(dose_failure(j).first, "dose.steps");
  j = dose_protocol();
  // A field outside the axis blocks, in a block the base has off.
  j["dose"]["settings"] = "../settings/high_fidelity.json";
  j["dose"]["field"] = "tip_force_saturation.limit_N";
  j["dose"]["strengths"] = {1.0, 2.0};
  const Protocol p = protocol_from_json(j, testing::kExampleProtocolsDir, "dose.json");
  EXPECT_EQ(p.settings[1].settings.name, "High Fidelity, limit_N = 1");
  EXPECT_TRUE(p.settings[1].settings.engine.tip_force_saturation.enabled);
}

}  // namespace
}  // namespace hapticlab::protocols
