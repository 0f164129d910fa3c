// Device presets (issues 19 §3 and 35 §3): settings with a "source" block
// that cites where each number comes from, set only what the source gives,
// and a force limit the device under the engine must be able to give.
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>

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
            {"fields",
             {{"peak force", nlohmann::json(limit_N).dump() + " N: tip_force_saturation.limit_N = " +
                                 nlohmann::json(limit_N).dump()},
              {"friction", "not published"}}}}}};
}

// The eight quantities of a specification sheet that the engine can stand
// for (docs/settings.md, "Device presets"), and the blocks each one is.
const std::map<std::string, std::vector<std::string>>& specification() {
  static const std::map<std::string, std::vector<std::string>> spec = {
      {"peak force", {"tip_force_saturation"}},
      {"continuous force", {}},
      {"friction", {"translation.friction", "rotation.friction"}},
      {"back-drive inertia", {"translation.inertia", "rotation.inertia"}},
      {"cogging", {"translation.cogging", "rotation.cogging"}},
      {"backlash", {"translation.backlash", "rotation.backlash"}},
      {"encoder resolution", {"translation.encoder", "rotation.encoder"}},
      {"update rate", {}}};
  return spec;
}

bool block_on(const nlohmann::json& settings, const std::string& block) {
  const nlohmann::json* b = find_settings_field(settings, block);
  return b != nullptr && b->value("enabled", false);
}

// Every shipped preset cites its device and the documents, says for each
// quantity of a specification sheet what they give (a value or "not
// published"), switches on nothing they do not give, and states every
// number it sets as "field = value" in the quantity it comes from. At least
// three presets fill four or more of the eight quantities, and the open
// low-cost device (WoodenHaptics) has one.
TEST(DevicePresetTest, EveryShippedPresetCitesEachQuantityAndUsesOnlyWhatItCites) {
  std::set<std::string> names;
  int with_four_or_more = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kDevices)) {
    if (entry.path().extension() != ".json") continue;
    const NamedSettings s = load_settings_file(entry.path());
    names.insert(s.name);
    ASSERT_TRUE(s.source.has_value()) << entry.path();
    std::map<std::string, std::string> quantities(s.source->fields.begin(), s.source->fields.end());
    for (const char* q : {"workspace", "stiffness"})
      EXPECT_TRUE(quantities.count(q)) << entry.path() << " does not say what its source gives for " << q;
    const nlohmann::json j = settings_to_json(s);
    int filled = 0;
    for (const auto& [quantity, blocks] : specification()) {
      ASSERT_TRUE(quantities.count(quantity)) << entry.path() << " does not say what its source gives for "
                                              << quantity;
      const std::string& what = quantities[quantity];
      const bool published = what.find("not published") == std::string::npos;
      filled += published ? 1 : 0;
      if (published) continue;
      // Off, unless another quantity the source gives sets it (a continuous
      // force where no peak is published).
      for (const std::string& block : blocks) {
        bool set_by_another = false;
        for (const auto& [other, text] : quantities)
          set_by_another = set_by_another || (text.find("not published") == std::string::npos &&
                                              text.find(block + ".") != std::string::npos);
        EXPECT_TRUE(!block_on(j, block) || set_by_another)
            << entry.path() << ": " << block << " is on, but " << quantity << " is not published";
      }
    }
    if (filled >= 4) ++with_four_or_more;
    // Each field in force away from its default is given as "field = value".
    for (const SettingsFieldInfo& f : settings_field_reference()) {
      if (f.path.starts_with("device_limits") || f.path == "min_moment_arm_m") continue;
      const std::vector<std::string> parts = split_settings_field(f.path);
      const std::string block = f.path.substr(0, f.path.rfind('.'));
      const double v = find_settings_field(j, f.path)->get<double>();
      const nlohmann::json* enabled = find_settings_field(j, block + ".enabled");
      if ((enabled != nullptr && !enabled->get<bool>()) || v == f.default_value) continue;
      bool stated = false;
      for (const auto& [quantity, what] : quantities)
        stated = stated || what.find(f.path + " = ") != std::string::npos;
      EXPECT_TRUE(stated) << entry.path() << ": " << f.path << " = " << v << " is not stated in the source";
    }
    EXPECT_LE(s.engine.tip_force_saturation.limit_N, s.engine.device_limits.insertion_force_N);
    // The source survives a write and a read (a stored copy keeps it).
    const NamedSettings back = settings_from_json(settings_to_json(s), "round trip");
    ASSERT_TRUE(back.source.has_value());
    EXPECT_EQ(back.source->fields, s.source->fields);
    EXPECT_EQ(back.source->reference, s.source->reference);
  }
  EXPECT_EQ(names, (std::set<std::string>{"PHANTOM Omni", "Touch", "Novint Falcon", "omega.3", "WoodenHaptics",
                                          "Mini WoodenHaptics"}));
  EXPECT_GE(with_four_or_more, 3);
}

TEST(DevicePresetTest, AForceLimitBeyondTheDeviceIsRefusedNamingBothFields) {
  EXPECT_EQ(error_of(preset(2.0)), "(no error)");
  EXPECT_EQ(error_of(preset(25.0)),
            "preset.json: tip_force_saturation.limit_N is 25 N, but this device preset's device can give only 19 N "
            "along the tool (device_limits.insertion_force_N): the engine cannot make it feel like the device "
            "named in source.device");
  nlohmann::json stronger = preset(25.0);
  stronger["device_limits"] = {{"insertion_force_N", 30.0}};
  EXPECT_EQ(error_of(stronger), "(no error)");  // the device under the engine needs no source
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

// Issue 35 §5: a preset sets only what its source gives. A number set
// without a source entry naming it, a block switched on with no number from
// the source, a source entry whose number the preset does not use, or one
// that names a field the preset leaves off, is refused, naming the field.
TEST(DevicePresetTest, AnUnsourcedFieldIsRefusedNamingIt) {
  nlohmann::json j = preset(2.0);
  j["translation"] = {{"friction", {{"dynamic_level_N", 0.7}}}};
  EXPECT_EQ(error_of(j),
            "preset.json: settings field 'translation.friction.dynamic_level_N' is 0.7 in this device preset, but no "
            "source.fields entry names it: every number a preset sets comes from its source (write "
            "\"translation.friction.dynamic_level_N = 0.7\" in the quantity it comes from)");
  j["source"]["fields"]["friction"] = "0.7 N inwards: translation.friction.dynamic_level_N = 0.7";
  EXPECT_EQ(error_of(j), "(no error)");
  j["source"]["fields"]["friction"] = "0.7 N inwards: translation.friction.dynamic_level_N = 0.8";
  EXPECT_EQ(error_of(j), "preset.json: source.fields.friction gives translation.friction.dynamic_level_N = 0.8, "
                         "but this device preset sets it to 0.7");
  // The first presets' form, the field's name alone, still cites it (stored copies of them load).
  j["source"]["fields"]["friction"] = "0.7 N inwards (translation.friction.dynamic_level_N)";
  EXPECT_EQ(error_of(j), "(no error)");
  // A longer name is not the field's.
  j["source"]["fields"]["friction"] = "see translation.friction.dynamic_level_Nx";
  EXPECT_THAT(error_of(j), HasSubstr("'translation.friction.dynamic_level_N' is 0.7 in this device preset, but no "
                                     "source.fields entry names it"));
  // A block switched on at the model's defaults is no number from the source.
  j = preset(2.0);
  j["rotation"] = {{"inertia", nlohmann::json::object()}};
  EXPECT_EQ(error_of(j), "preset.json: settings block 'rotation.inertia' is on in this device preset, but no "
                         "source.fields entry names any of its fields: a preset switches on only what its source "
                         "gives");
  // A cited field whose block the preset leaves off.
  j = preset(2.0);
  j["source"]["fields"]["update rate"] = "1 kHz: loop.hold_rate_Hz = 1000";
  EXPECT_EQ(error_of(j), "preset.json: source.fields.update rate gives loop.hold_rate_Hz = 1000, but this device "
                         "preset sets it to 0");
  j = preset(2.0);
  j["source"]["fields"]["encoder resolution"] = "64 um: translation.encoder.counts_per_m = 15600";
  j["translation"] = {{"encoder", {{"enabled", false}, {"counts_per_m", 15600}}}};
  EXPECT_EQ(error_of(j), "preset.json: source.fields.encoder resolution names translation.encoder.counts_per_m, "
                         "but this device preset leaves 'translation.encoder' off: a quantity its source gives is "
                         "in force");
  // A whole stored copy (every field written out) of a shipped preset loads;
  // at another strength a preset is no longer its device and drops its source.
  const NamedSettings falcon = load_settings_file(kDevices / "novint_falcon.json");
  EXPECT_NO_THROW(settings_from_json(settings_to_json(falcon), "stored copy"));
  const NamedSettings weaker = settings_at_strength(falcon, "translation.friction.dynamic_level_N", 1.0);
  EXPECT_FALSE(weaker.source.has_value());
  EXPECT_EQ(weaker.engine.translation.friction.dynamic_level, 1.0);
  EXPECT_EQ(weaker.name, "Novint Falcon, dynamic_level_N = 1");
}

}  // namespace
}  // namespace hapticlab
