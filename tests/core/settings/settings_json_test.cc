#include "core/settings/settings_json.h"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace hapticlab {
namespace {

using ::testing::HasSubstr;

const std::string kExamples = std::string(HAPTICLAB_SOURCE_DIR) + "/examples/settings/";

std::string error_of(const std::string& text) {
  try {
    settings_from_json_text(text, "test.json");
  } catch (const SettingsError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(SettingsJsonTest, EveryShippedExampleLoadsAndValidates) {
  int count = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kExamples)) {
    if (entry.path().extension() != ".json") continue;
    const NamedSettings s = load_settings_file(entry.path());
    EXPECT_FALSE(s.name.empty()) << entry.path();
    EXPECT_NO_THROW(validate_settings(s.engine)) << entry.path();
    ++count;
  }
  EXPECT_EQ(count, 9);  // the thesis' 8 settings + the maximum stable set
}

TEST(SettingsJsonTest, ThesisTable31ValuesInTheExamples) {
  const EngineSettings all = load_settings_file(kExamples + "all_degradations.json").engine;
  EXPECT_TRUE(all.tip_force_saturation.enabled);
  EXPECT_EQ(all.tip_force_saturation.limit_N, 1.0);
  EXPECT_EQ(all.translation.cogging.amplitude, 0.45);
  EXPECT_EQ(all.rotation.cogging.amplitude, 0.030);
  EXPECT_EQ(all.translation.inertia.mass, 0.1);
  EXPECT_EQ(all.rotation.inertia.mass, 0.001);
  EXPECT_EQ(all.translation.backlash.gap, 0.002);
  EXPECT_EQ(all.rotation.backlash.gap, 0.04);
  EXPECT_FALSE(all.translation.friction.enabled);  // not part of All Degradations (3.3.3)
  const EngineSettings nffb = load_settings_file(kExamples + "no_force_feedback.json").engine;
  EXPECT_TRUE(nffb.tip_force_saturation.enabled);
  EXPECT_EQ(nffb.tip_force_saturation.limit_N, 0.0);
}

TEST(SettingsJsonTest, EmptyBlocksTakeTheThesisDefaults) {
  const EngineSettings s =
      settings_from_json_text(R"({"translation": {"friction": {}}, "rotation": {"inertia": {}}})",
                              "inline")
          .engine;
  EXPECT_TRUE(s.translation.friction.enabled);
  EXPECT_EQ(s.translation.friction.dynamic_level, 0.45);
  EXPECT_EQ(s.translation.friction.presliding_displacement, 1e-4);
  EXPECT_EQ(s.translation.friction.stick_velocity, 0.005);
  EXPECT_TRUE(s.rotation.inertia.enabled);
  EXPECT_EQ(s.rotation.inertia.mass, 0.001);
  EXPECT_EQ(s.rotation.inertia.stiffness, 4.0);
  EXPECT_EQ(s.rotation.inertia.damping_ratio, 0.2);
  EXPECT_FALSE(s.translation.cogging.enabled);
  EXPECT_EQ(s.device_limits.insertion_force_N, 19.0);  // Table 2.1 peak
  EXPECT_EQ(s.device_limits.pitch_torque_Nm, 0.85);
}

TEST(SettingsJsonTest, OutOfRangeNamesFieldValueAndRange) {
  const std::string e = error_of(R"({"translation": {"friction": {"dynamic_level_N": -0.2}}})");
  EXPECT_THAT(e, HasSubstr("test.json"));
  EXPECT_THAT(e, HasSubstr("translation.friction.dynamic_level_N"));
  EXPECT_THAT(e, HasSubstr("-0.2"));
  EXPECT_THAT(e, HasSubstr(">= 0 and <= 50"));
  EXPECT_THAT(error_of(R"({"rotation": {"inertia": {"stiffness_Nm_per_rad": 0}}})"),
              HasSubstr("'rotation.inertia.stiffness_Nm_per_rad' is 0, but must be > 0"));
  // The mass floor (docs/engine.md, Safety: a subnormal mass overflows).
  EXPECT_THAT(error_of(R"({"rotation": {"inertia": {"inertia_kg_m2": 1e-310}}})"),
              HasSubstr("'rotation.inertia.inertia_kg_m2' is 1e-310, but must be >= 1e-06 and <= 0.1"));
  // Values and bounds read back as the doubles they are: rounded to 10
  // digits, a value just outside a bound printed as the bound itself.
  EXPECT_THAT(error_of(R"({"rotation": {"cogging": {"period_rad": 6.28318530718}}})"),
              HasSubstr("is 6.28318530718, but must be >= 0.001 and <= 6.283185307179586"));
  EXPECT_THAT(error_of(R"({"translation": {"inertia": {"mass_kg": 0.000999999999999}}})"),
              HasSubstr("is 0.000999999999999, but must be >= 0.001"));
  EXPECT_THAT(error_of(R"({"translation": {"inertia": {"mass_kg": -0.0}}})"), HasSubstr("is -0, but must be"));
}

TEST(SettingsJsonTest, UnitsAreInEveryFieldName) {
  // The rotational block rejects translational names and says what it knows.
  const std::string e = error_of(R"({"rotation": {"friction": {"dynamic_level_N": 0.1}}})");
  EXPECT_THAT(e, HasSubstr("unknown settings field 'rotation.friction.dynamic_level_N'"));
  EXPECT_THAT(e, HasSubstr("dynamic_level_Nm"));
}

TEST(SettingsJsonTest, TyposTypesAndStructureAreErrors) {
  EXPECT_THAT(error_of(R"({"translation": {"inertia": {"mass_g": 100}}})"),
              HasSubstr("unknown settings field 'translation.inertia.mass_g'"));
  EXPECT_THAT(error_of(R"({"translation": {"inertia": {"mass_kg": "heavy"}}})"),
              HasSubstr("must be a number"));
  EXPECT_THAT(error_of(R"({"translation": {"cogging": {"enabled": 1}}})"),
              HasSubstr("must be true or false"));
  EXPECT_THAT(error_of(R"({"translation": {"frictoin": {}}})"),
              HasSubstr("unknown settings field 'translation.frictoin'"));
  EXPECT_THAT(error_of(R"({"translation": [1, 2]})"), HasSubstr("must be a JSON object"));
  EXPECT_THAT(error_of(R"({"translation": )"), HasSubstr("not valid JSON"));
}

TEST(SettingsJsonTest, BacklashNeedsInertia) {
  EXPECT_THAT(error_of(R"({"translation": {"backlash": {}}})"),
              HasSubstr("'translation.backlash' needs 'translation.inertia' enabled"));
  EXPECT_THAT(
      error_of(R"({"rotation": {"inertia": {}, "backlash": {"static_friction_Nm": 0.001, "dynamic_friction_Nm": 0.002}}})"),
      HasSubstr("must be <= static_friction_Nm"));
}

TEST(SettingsJsonTest, WrittenSettingsReadBackIdentically) {
  for (const char* name : {"max_stable", "all_degradations", "friction"}) {
    const NamedSettings a = load_settings_file(kExamples + name + ".json");
    const nlohmann::json j = settings_to_json(a);
    const NamedSettings b = settings_from_json(j, "round trip");
    EXPECT_EQ(settings_to_json(b), j) << name;
    EXPECT_EQ(b.name, a.name);
  }
}

TEST(SettingsJsonTest, ValidateCatchesSettingsBuiltInCode) {
  EngineSettings s;
  s.translation.inertia = {true, -1.0, 600.0, 0.3};
  try {
    validate_settings(s);
    FAIL() << "no error";
  } catch (const SettingsError& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("translation.inertia.mass_kg"));
  }
}

}  // namespace
}  // namespace hapticlab

namespace hapticlab {
namespace {

TEST(SettingsReferenceTest, DocsContainTheGeneratedFieldTable) {
  std::ifstream in(std::string(HAPTICLAB_SOURCE_DIR) + "/docs/settings.md");
  std::stringstream doc;
  doc << in.rdbuf();
  EXPECT_THAT(doc.str(), ::testing::HasSubstr(settings_reference_markdown()))
      << "regenerate the table with `hapticlab settings reference`";
}

}  // namespace
}  // namespace hapticlab
