// first_effect_on (core/settings/undegraded.h): the shipped High Fidelity is
// undegraded; a setting file that switches anything on is named by its
// first effect, in the settings file's order.
#include "core/settings/undegraded.h"

#include <filesystem>

#include <gtest/gtest.h>

#include "core/settings/settings_json.h"

namespace hapticlab {
namespace {

EngineSettings from(const char* text) { return settings_from_json_text(text, "test").engine; }

TEST(UndegradedTest, HighFidelityIsUndegradedAndAnEffectOnIsNamed) {
  const auto shipped = std::filesystem::path(HAPTICLAB_SOURCE_DIR) / "examples" / "settings";
  EXPECT_EQ(first_effect_on(load_settings_file(shipped / "high_fidelity.json").engine), "");
  // Lower device limits are the device under the engine, not an effect.
  EXPECT_EQ(first_effect_on(from(R"({"name": "x", "device_limits": {"insertion_force_N": 5}})")), "");
  EXPECT_EQ(first_effect_on(from(R"({"name": "x", "translation": {"friction": {"dynamic_level_N": 2.0}}})")),
            "translation.friction");
  EXPECT_EQ(first_effect_on(from(R"({"name": "x", "rotation": {"encoder": {"counts_per_rad": 1000}}})")),
            "rotation.encoder");
  EXPECT_EQ(first_effect_on(load_settings_file(shipped / "no_force_feedback.json").engine), "tip_force_saturation");
  EXPECT_EQ(first_effect_on(from(R"({"name": "x", "loop": {"force_latency_s": 0.01}})")), "loop.force_latency_s");
  // Several on: the first in the file's order (translation before rotation).
  EXPECT_EQ(first_effect_on(load_settings_file(shipped / "all_degradations.json").engine).rfind("translation.", 0), 0u);
}

}  // namespace
}  // namespace hapticlab
