// Device presets (issue 19 §3): settings with a "source" block that cites
// where each number comes from, and a force limit the device under the
// engine must be able to give.
#include <filesystem>
#include <set>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "core/settings/settings_json.h"

namespace hapticlab {
namespace {

using ::testing::HasSubstr;

const std::filesystem::path kDevices = std::filesystem::path(HAPTICLAB_SOURCE_DIR) / "examples/settings/devices";

std::string error_of(const nlohmann::json& j) {
  try {
    settings_from_json(j, "preset.json");
  } catch (const SettingsError& e) {
    return e.what();
  }
  return "(no error)";
}

nlohmann::json preset(double limit_N) {
  return {{"name", "Cheap"},
          {"tip_force_saturation", {{"limit_N", limit_N}}},
          {"source",
           {{"device", "Cheap Device"},
            {"reference", "its sheet, rev 1"},
            {"fields", {{"peak force", "2 N"}, {"friction", "not published"}}}}}};
}

// Every shipped preset cites its device and the document, names every
// quantity of a specification sheet (a value or "not published"), limits
// the tip force to the peak force it cites, and switches on nothing the
// source does not give.
TEST(DevicePresetTest, EveryShippedPresetCitesEachQuantityAndUsesOnlyWhatItCites) {
  int count = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kDevices)) {
    if (entry.path().extension() != ".json") continue;
    ++count;
    const NamedSettings s = load_settings_file(entry.path());
    ASSERT_TRUE(s.source.has_value()) << entry.path();
    std::set<std::string> quantities;
    for (const auto& [quantity, what] : s.source->fields) quantities.insert(quantity);
    for (const char* q : {"peak force", "continuous force", "workspace", "stiffness", "friction",
                          "back-drive inertia", "cogging", "encoder resolution", "update rate"})
      EXPECT_TRUE(quantities.count(q)) << entry.path() << " does not say what its source gives for " << q;
    for (const auto& [quantity, what] : s.source->fields) {
      if (quantity == "friction") {
        EXPECT_THAT(what, HasSubstr("not published"));
        EXPECT_FALSE(s.engine.translation.friction.enabled || s.engine.rotation.friction.enabled);
      }
      if (quantity == "back-drive inertia") {
        EXPECT_FALSE(s.engine.translation.inertia.enabled);
      }
      if (quantity == "cogging") {
        EXPECT_FALSE(s.engine.translation.cogging.enabled);
      }
      if (quantity == "peak force") {
        ASSERT_TRUE(s.engine.tip_force_saturation.enabled);
        EXPECT_THAT(what, HasSubstr(nlohmann::json(s.engine.tip_force_saturation.limit_N).dump() + " N"))
            << entry.path();
      }
    }
    EXPECT_LE(s.engine.tip_force_saturation.limit_N, s.engine.device_limits.insertion_force_N);
    // The source survives a write and a read (a stored copy keeps it).
    const NamedSettings back = settings_from_json(settings_to_json(s), "round trip");
    ASSERT_TRUE(back.source.has_value());
    EXPECT_EQ(back.source->fields, s.source->fields);
    EXPECT_EQ(back.source->reference, s.source->reference);
  }
  EXPECT_EQ(count, 4);
}

TEST(DevicePresetTest, AForceLimitBeyondTheDeviceIsRefusedNamingBothFields) {
  EXPECT_EQ(error_of(preset(2.0)), "(no error)");
  EXPECT_EQ(error_of(preset(25.0)),
            "preset.json: tip_force_saturation.limit_N is 25 N, but this device preset's device can give only 19 N "
            "along the tool (device_limits.insertion_force_N): the engine cannot make it feel like the device "
            "named in source.device");
  nlohmann::json stronger = preset(25.0);
  stronger["device_limits"] = {{"insertion_force_N", 30.0}};
  EXPECT_EQ(error_of(stronger), "(no error)");
  // Without a source it is not a preset: a limit above the device's is
  // only never reached.
  nlohmann::json plain = preset(25.0);
  plain.erase("source");
  EXPECT_EQ(error_of(plain), "(no error)");
}

TEST(DevicePresetTest, AnIncompleteSourceIsRefusedNamingTheField) {
  nlohmann::json j = preset(2.0);
  j["source"].erase("reference");
  EXPECT_EQ(error_of(j), "preset.json: settings field 'source.reference' is missing");
  j = preset(2.0);
  j["source"]["url"] = "x";
  EXPECT_THAT(error_of(j), HasSubstr("unknown settings field 'source.url' (known: device, reference, fields)"));
  j = preset(2.0);
  j["source"]["fields"]["friction"] = "";
  EXPECT_EQ(error_of(j), "preset.json: settings field 'source.fields.friction' must be a non-empty string");
  j = preset(2.0);
  j["source"]["fields"] = nlohmann::json::object();
  EXPECT_THAT(error_of(j), HasSubstr("settings field 'source.fields' must be an object naming each quantity"));
}

}  // namespace
}  // namespace hapticlab
