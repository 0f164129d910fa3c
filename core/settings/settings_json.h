#pragma once
// JSON settings files: load, validate, write.
//
// Every physical field carries its SI unit in its name. The insertion axis is
// configured under "translation" (N, m, kg), pitch and yaw under "rotation"
// (Nm, rad, kg·m²); the field names are built from one table for both, e.g.
// translation.friction.dynamic_level_N and rotation.friction.dynamic_level_Nm.
// A model block that is present is enabled unless it says "enabled": false;
// fields it leaves out take the defaults listed in docs/settings.md (thesis
// Tables 2.2 and 3.1). Unknown fields are errors, so a typo never silently
// runs with a default.
//
// Loading validates every field and throws SettingsError naming the field,
// the value and the allowed range; nothing partial is ever returned.

#include <filesystem>
#include <optional>
#include <utility>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "core/settings/settings.h"

namespace hapticlab {

class SettingsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Where a device preset's numbers come from (examples/settings/devices/):
// the device, the document cited, and for each quantity of a specification
// sheet what that document gives, or "not published". Settings that carry a
// source are a device preset: their force limit must be one the device
// under the engine can give (device_limits).
struct SettingsSource {
  std::string device;     // e.g. "Novint Falcon"
  std::string reference;  // the document, with version, file and field
  // quantity -> what the reference says (or "not published ..."), in the
  // file's key order sorted by name.
  std::vector<std::pair<std::string, std::string>> fields;
};

struct NamedSettings {
  std::string name;         // e.g. "All Degradations"
  std::string description;  // free text
  EngineSettings engine;
  std::optional<SettingsSource> source{};  // device presets only
};

// The source block as text for a terminal: "Source: DEVICE\n  reference: ...\n  quantity: ...".
std::string source_text(const SettingsSource& source);

// `source` names the origin in error messages (a file path, "inline", ...).
NamedSettings settings_from_json(const nlohmann::json& j, const std::string& source);
NamedSettings settings_from_json_text(std::string_view text, const std::string& source);
NamedSettings load_settings_file(const std::filesystem::path& path);

// The full settings, every block and field written out (a stored copy must
// not depend on defaults that may change).
nlohmann::json settings_to_json(const NamedSettings& s);

// A field named by its dotted path ("translation.friction.dynamic_level_N",
// "tip_force_saturation.limit_N") in a settings_to_json object: the keys from
// the top down, and the field's value (nullptr when there is no such key).
// The stability map, dose protocols and their analysis all name fields so.
std::vector<std::string> split_settings_field(std::string_view dotted);
const nlohmann::json* find_settings_field(const nlohmann::json& settings, std::string_view dotted);

// The name a dose protocol (docs/protocols.md) gives its setting at
// `strength`: "<base>, <key> = <strength>", key the field's last part, e.g.
// "Insertion friction, dynamic_level_N = 0.45". The analysis finds the
// series by it.
std::string dose_setting_name(std::string_view base, std::string_view field, double strength);

// `base` with `field` (dotted) set to `strength` and its effect switched on,
// named dose_setting_name(base.name, field, strength): one strength of a dose
// series or a staircase. Throws SettingsError naming the field when the
// strength is outside its range or the field is not a number of `base`.
NamedSettings settings_at_strength(const NamedSettings& base, std::string_view field, double strength);

// Checks settings built in code against the same ranges the loader uses.
void validate_settings(const EngineSettings& s);

// Every numeric field with its default and allowed range, from the same
// table the loader uses: what a slider may offer (the console's tuning page).
struct SettingsFieldInfo {
  std::string path;  // e.g. "translation.friction.dynamic_level_N"
  double default_value = 0.0;
  double lo = 0.0, hi = 0.0;  // allowed: lo <= v (lo < v when lo_exclusive), v <= hi
  bool lo_exclusive = false;
};
std::vector<SettingsFieldInfo> settings_field_reference();

// Markdown table of every field with its default and allowed range, made
// from the same table the loader uses (docs/settings.md embeds it).
std::string settings_reference_markdown();

}  // namespace hapticlab
