// Plan power's design check (planning/plan_design.h), without the CLI: an
// undeclared copy of the control is a null setting with a note; a declared
// null setting that differs from the control is refused naming the field;
// one that is the control itself is refused.
#include "planning/plan_design.h"

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "protocols/protocol_json.h"
#include "testing/scratch_dir.h"

namespace hapticlab::planning {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

class PlanDesignTest : public ::testing::Test {
 protected:
  PlanDesignTest() : dir_(scratch_.path()) {
    std::ofstream(dir_ / "copy.json") << R"({"name": "HF copy", "description": "the control again"})";
  }
  // A protocol of High Fidelity (the control), Friction and "HF copy",
  // with `null_settings` (a JSON array) declared.
  std::string protocol(const std::string& null_settings) const {
    const fs::path settings = fs::path(HAPTICLAB_SOURCE_DIR) / "examples" / "settings";
    const fs::path path = dir_ / "protocol.json";
    std::ofstream(path) << R"({"study": "design test", "tasks": ["clip"], "repetitions": {"clip": 1},
      "settings": [")" << (settings / "high_fidelity.json").string() << R"(", ")"
                        << (settings / "friction.json").string() << R"(", ")" << (dir_ / "copy.json").string()
                        << R"("], "null_settings": )" << null_settings << R"(,
      "participants": ["P01", "P02", "P03"], "design": {"type": "complete"}, "training_trials": 0, "seed": 7})";
    return path.string();
  }
  testing::ScratchDir scratch_;
  fs::path dir_;
};

TEST_F(PlanDesignTest, AnUndeclaredCopyOfTheControlIsANullSettingWithANote) {
  const std::string path = protocol("[]");
  const PlanDesign d = check_plan_design(protocols::load_protocol_file(path), path, {3}, 1, {});
  EXPECT_EQ(d.control, "High Fidelity");
  EXPECT_EQ(d.null_settings, (std::set<std::string>{"HF copy"}));
  ASSERT_EQ(d.notes.size(), 1u);
  EXPECT_THAT(d.notes[0], HasSubstr("'HF copy' has the control's parameters: counted as a null setting"));
  // Declared, it is a null setting without a note.
  const std::string declared = protocol(R"(["HF copy"])");
  const PlanDesign e = check_plan_design(protocols::load_protocol_file(declared), declared, {3}, 1, {});
  EXPECT_EQ(e.null_settings, (std::set<std::string>{"HF copy"}));
  EXPECT_TRUE(e.notes.empty());
}

TEST_F(PlanDesignTest, ADeclaredNullSettingThatIsNotACopyOrIsTheControlIsRefusedByName) {
  const std::string differs = protocol(R"(["Friction"])");
  try {
    check_plan_design(protocols::load_protocol_file(differs), differs, {3}, 1, {});
    FAIL() << "a null setting that differs from the control was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr(differs + ": null_settings names 'Friction', but it is not a copy of the control "
                                               "'High Fidelity': it differs at rotation.friction.enabled (a null setting has "
                                               "the control's parameters under another name)"));
  }
  const std::string control = protocol(R"(["High Fidelity"])");
  try {
    check_plan_design(protocols::load_protocol_file(control), control, {3}, 1, {});
    FAIL() << "the control accepted as its own null setting";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("null_settings names 'High Fidelity', the control itself"));
  }
  // Named twice: refused when the protocol is read, as tasks and required are.
  const std::string twice = protocol(R"(["HF copy", "HF copy"])");
  try {
    protocols::load_protocol_file(twice);
    FAIL() << "a null setting named twice was accepted";
  } catch (const std::exception& e) {
    EXPECT_THAT(e.what(), HasSubstr("'null_settings[1]' is \"HF copy\", the same as null_settings[0]; name each "
                                    "setting once"));
  }
}

// The control is found by its name, but judged by what it does: a 'High
// Fidelity' with friction on is refused, naming the setting and the effect.
TEST_F(PlanDesignTest, AControlThatDegradesSomethingIsRefusedNamingTheEffect) {
  const fs::path path = dir_ / "degraded.json";
  std::ofstream(path) << R"({"study": "d", "tasks": ["clip"], "repetitions": {"clip": 1}, "settings": [
      {"name": "High Fidelity", "translation": {"friction": {"dynamic_level_N": 2.0}}},
      {"name": "Other", "rotation": {"friction": {"dynamic_level_Nm": 0.1}}}],
      "participants": ["P01"], "design": {"type": "complete"}, "seed": 7})";
  try {
    check_plan_design(protocols::load_protocol_file(path), path.string(), {1}, 1, {});
    FAIL() << "a degraded control was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr(path.string() + ": the control 'High Fidelity' has translation.friction on, but "
                                                    "plan power measures every effect against an undegraded control"));
  }
}

}  // namespace
}  // namespace hapticlab::planning
