#include "core/settings/settings_json.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <set>
#include <sstream>
#include <system_error>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/common/csv_format.h"
#include "core/common/input_file.h"

namespace hapticlab {
namespace {

using nlohmann::json;

// One numeric field: its JSON key, where it lives, what is allowed, its default.
struct Field {
  std::string key;
  double* value;
  double lo;
  double hi;
  bool lo_exclusive;
  double default_value;
};

// One block of fields; `enabled` is null for blocks that cannot be switched off.
struct Block {
  std::string name;
  bool* enabled;
  std::vector<Field> fields;
};

// The shortest text that reads back as the same double: a bound or a value
// rounded to 10 digits made "is 6.283185307, but must be ... <= 6.283185307"
// (the value just above 2π) and "is 0.001, but must be >= 0.001".
std::string format_number(double v) { return hapticlab::format_number<double>(v); }

std::string range_text(const Field& f) {
  return std::string("must be ") + (f.lo_exclusive ? "> " : ">= ") + format_number(f.lo) +
         " and <= " + format_number(f.hi);
}

void check_range(const std::string& path, const Field& f, double v) {
  const bool low_ok = f.lo_exclusive ? v > f.lo : v >= f.lo;
  if (!std::isfinite(v) || !low_ok || v > f.hi) {
    throw SettingsError("settings field '" + path + "' is " + format_number(v) +
                        ", but " + range_text(f));
  }
}

// The model blocks of one axis kind. Field names, ranges and defaults differ
// between translation and rotation only in units and magnitudes.
std::vector<Block> axis_blocks(AxisKind kind, AxisSettings& s) {
  const bool t = kind == AxisKind::kTranslation;
  const std::string F = t ? "N" : "Nm";
  const std::string X = t ? "m" : "rad";
  const double max_force = t ? 50.0 : 5.0;
  const double two_pi = 2.0 * std::numbers::pi;
  // Default cogging period: see core/models/cogging.h.
  const double cog_period = t ? 0.010 : two_pi / 60.0;

  std::vector<Block> b;
  // Thesis Table 3.1 level and pre-sliding, Table 2.2 stick velocity.
  b.push_back({"friction", &s.friction.enabled,
               {{"dynamic_level_" + F, &s.friction.dynamic_level, 0, max_force, false, t ? 0.45 : 0.030},
                {"presliding_displacement_" + X, &s.friction.presliding_displacement, 0,
                 t ? 0.01 : 0.1, true, t ? 1e-4 : 0.01},
                {"stick_velocity_" + X + "_per_s", &s.friction.stick_velocity, 0, t ? 1.0 : 10.0,
                 true, t ? 0.005 : 0.1}}});
  b.push_back({"cogging", &s.cogging.enabled,
               {{"amplitude_" + F, &s.cogging.amplitude, 0, max_force, false, t ? 0.45 : 0.030},
                {"period_" + X, &s.cogging.period, t ? 5e-4 : 1e-3, t ? 1.0 : two_pi, false, cog_period},
                {"phase_rad", &s.cogging.phase_rad, -two_pi, two_pi, false, 0.0},
                {"ripple_fraction", &s.cogging.ripple_fraction, 0, 0.5, false, 0.0},
                {"ripple_period_" + X, &s.cogging.ripple_period, t ? 5e-4 : 1e-3, t ? 1.0 : two_pi,
                 false, cog_period}}});
  // Thesis Table 3.1: 1 N; rotation is N/A there, 0.1 Nm is 1 N at 10 cm.
  b.push_back({"saturation", &s.saturation.enabled,
               {{"level_" + F, &s.saturation.level, 0, max_force, false, t ? 1.0 : 0.1}}});
  // Table 3.1 mass, Table 2.2 K and damping ratio. The floor, 1 g (or
  // 1e-6 kg·m², a gram at 3 cm), is lighter than any instrument handle, so
  // it costs no real setting; an unbounded "> 0" admitted subnormal masses
  // whose free motion in the backlash gap (F·dt/m per update) overflows.
  b.push_back({"inertia", &s.inertia.enabled,
               {{t ? "mass_kg" : "inertia_kg_m2", &s.inertia.mass, t ? 1e-3 : 1e-6, t ? 10.0 : 0.1, false,
                 t ? 0.1 : 0.001},
                {"stiffness_" + F + "_per_" + X, &s.inertia.stiffness, 0, t ? 1e5 : 1e3, true,
                 t ? 600.0 : 4.0},
                {"damping_ratio", &s.inertia.damping_ratio, 0, 2.0, false, t ? 0.3 : 0.2}}});
  // Table 3.1 gap; the Karnopp friction on the free mass is "a small amount"
  // in the thesis: about a tenth of the friction degradation's level.
  b.push_back({"backlash", &s.backlash.enabled,
               {{"gap_" + X, &s.backlash.gap, 0, t ? 0.05 : 0.5, true, t ? 0.002 : 0.04},
                {"static_friction_" + F, &s.backlash.static_friction, 0, max_force, false,
                 t ? 0.05 : 0.003},
                {"dynamic_friction_" + F, &s.backlash.dynamic_friction, 0, max_force, false,
                 t ? 0.04 : 0.0025},
                {"stick_velocity_" + X + "_per_s", &s.backlash.stick_velocity, 0, t ? 1.0 : 10.0,
                 false, t ? 0.001 : 0.02}}});
  // Default resolution: the LSW's sensors, Table 2.1 (0.008 mm, 0.01°).
  b.push_back({"encoder", &s.encoder.enabled,
               {{"counts_per_" + X, &s.encoder.counts_per_unit, 1, 1e9, false,
                 t ? 125000.0 : 5729.58}}});
  // Time-domain passivity (core/models/passivity.h; docs/engine.md): not in
  // the thesis. Window 1 s: longer than the models (the virtual mass, a
  // cogging detent) take to store and give back energy at hand speeds, so a
  // passive set is left alone (0.3 % RMS force change with Table 4.1's set;
  // 0.1 s changed it by 10 %); still many periods of a buzzing contact.
  // Velocity floor: below the
  // filtered velocity's noise at the LSW's resolution. Damping cap: a
  // choice, about what a desktop device renders without buzzing; set it to
  // your device's (its Z-width, Colgate & Brown 1994).
  b.push_back({"passivity", &s.passivity.enabled,
               {{"window_s", &s.passivity.window_s, 0, kMaxPassivityWindow_s, true, 1.0},
                {"min_velocity_" + X + "_per_s", &s.passivity.min_velocity, 0, t ? 1.0 : 10.0, true,
                 t ? 1e-3 : 1e-2},
                {"max_damping_" + F + "_s_per_" + X, &s.passivity.max_damping, 0, t ? 1000.0 : 10.0, true,
                 t ? 20.0 : 0.2}}});
  return b;
}

std::vector<Block> engine_blocks(EngineSettings& s) {
  std::vector<Block> b;
  b.push_back({"tip_force_saturation", &s.tip_force_saturation.enabled,
               {{"limit_N", &s.tip_force_saturation.limit_N, 0, 100.0, false, 1.0}}});
  b.push_back({"loop", nullptr,
               {{"hold_rate_Hz", &s.loop.hold_rate_Hz, 0, 2000.0, false, 0.0},
                {"position_latency_s", &s.loop.position_latency_s, 0, 0.1, false, 0.0},
                {"force_latency_s", &s.loop.force_latency_s, 0, 0.1, false, 0.0}}});
  b.push_back({"device_limits", nullptr,
               {{"insertion_force_N", &s.device_limits.insertion_force_N, 0, 1000.0, true, 19.0},
                {"pitch_torque_Nm", &s.device_limits.pitch_torque_Nm, 0, 100.0, true, 0.85},
                {"yaw_torque_Nm", &s.device_limits.yaw_torque_Nm, 0, 100.0, true, 0.85}}});
  return b;
}

Field moment_arm_field(EngineSettings& s) {
  return {"min_moment_arm_m", &s.min_moment_arm_m, 0.001, 0.5, false, 0.02};
}

std::string known_keys(const Block& b) {
  std::string out = b.enabled ? "enabled" : "";
  for (const Field& f : b.fields) out += (out.empty() ? "" : ", ") + f.key;
  return out;
}

const json& expect_object(const json& j, const std::string& path) {
  if (!j.is_object()) {
    throw SettingsError("settings field '" + path + "' must be a JSON object, got " +
                        std::string(j.type_name()));
  }
  return j;
}

// Reads a block present in the file: enabled unless told otherwise; absent
// fields take defaults; unknown keys are rejected.
void read_block(const json& j, const std::string& path, Block& b) {
  expect_object(j, path);
  for (Field& f : b.fields) *f.value = f.default_value;
  if (b.enabled) *b.enabled = true;
  for (const auto& [key, value] : j.items()) {
    const std::string field_path = path + "." + key;
    if (key == "enabled" && b.enabled) {
      if (!value.is_boolean()) {
        throw SettingsError("settings field '" + field_path + "' must be true or false, got " +
                            value.dump());
      }
      *b.enabled = value.get<bool>();
      continue;
    }
    // An init-capture: clang before 16 cannot capture a structured binding.
    auto it = std::find_if(b.fields.begin(), b.fields.end(),
                           [&key = key](const Field& f) { return f.key == key; });
    if (it == b.fields.end()) {
      throw SettingsError("unknown settings field '" + field_path + "' (known fields: " +
                          known_keys(b) + ")");
    }
    if (!value.is_number()) {
      throw SettingsError("settings field '" + field_path + "' must be a number, got " +
                          value.dump() + "; " + range_text(*it));
    }
    *it->value = value.get<double>();
    check_range(field_path, *it, *it->value);
  }
}

void read_blocks(const json& j, const std::string& prefix, std::vector<Block>& blocks,
                 const std::set<std::string>& other_keys) {
  expect_object(j, prefix.empty() ? "(top level)" : prefix);
  for (const auto& [key, value] : j.items()) {
    if (other_keys.count(key)) continue;
    auto it = std::find_if(blocks.begin(), blocks.end(),
                           [&key = key](const Block& b) { return b.name == key; });
    const std::string path = prefix.empty() ? key : prefix + "." + key;
    if (it == blocks.end()) {
      std::string known;
      for (const Block& b : blocks) known += (known.empty() ? "" : ", ") + b.name;
      for (const std::string& k : other_keys) known += ", " + k;
      throw SettingsError("unknown settings field '" + path + "' (known: " + known + ")");
    }
    read_block(value, path, *it);
  }
}

// Rules that involve more than one field.
void check_cross_fields(const EngineSettings& s) {
  for (AxisKind kind : {AxisKind::kTranslation, AxisKind::kRotation}) {
    const AxisSettings& a = kind == AxisKind::kTranslation ? s.translation : s.rotation;
    const std::string name = kind == AxisKind::kTranslation ? "translation" : "rotation";
    const std::string F = kind == AxisKind::kTranslation ? "N" : "Nm";
    if (a.backlash.enabled && !a.inertia.enabled) {
      throw SettingsError("settings block '" + name + ".backlash' needs '" + name +
                          ".inertia' enabled: the gap lies between the instrument and the "
                          "virtual mass, whose mass and coupling come from the inertia block");
    }
    if (a.backlash.enabled && a.backlash.dynamic_friction > a.backlash.static_friction) {
      throw SettingsError("settings field '" + name + ".backlash.dynamic_friction_" + F +
                          "' is " + format_number(a.backlash.dynamic_friction) +
                          ", but must be <= static_friction_" + F + " (" +
                          format_number(a.backlash.static_friction) + ")");
    }
  }
}

json block_to_json(const Block& b) {
  json out = json::object();
  if (b.enabled) out["enabled"] = *b.enabled;
  for (const Field& f : b.fields) out[f.key] = *f.value;
  return out;
}

// Fills every field of a default-constructed EngineSettings with its default,
// leaving all blocks disabled.
EngineSettings defaults() {
  EngineSettings s;
  auto fill = [](std::vector<Block> blocks) {
    for (Block& b : blocks)
      for (Field& f : b.fields) *f.value = f.default_value;
  };
  fill(axis_blocks(AxisKind::kTranslation, s.translation));
  fill(axis_blocks(AxisKind::kRotation, s.rotation));
  fill(engine_blocks(s));
  *moment_arm_field(s).value = moment_arm_field(s).default_value;
  return s;
}

SettingsSource read_source(const json& j) {
  auto text = [](const json& v, const std::string& field) {
    if (!v.is_string() || v.get<std::string>().empty())
      throw SettingsError("settings field '" + field + "' must be a non-empty string");
    return v.get<std::string>();
  };
  if (!j.is_object()) throw SettingsError("settings field 'source' must be an object with device, reference and fields");
  for (const auto& [key, value] : j.items()) {
    (void)value;
    if (key != "device" && key != "reference" && key != "fields")
      throw SettingsError("unknown settings field 'source." + key + "' (known: device, reference, fields)");
  }
  SettingsSource out;
  for (const char* key : {"device", "reference", "fields"})
    if (!j.contains(key)) throw SettingsError(std::string("settings field 'source.") + key + "' is missing");
  out.device = text(j["device"], "source.device");
  out.reference = text(j["reference"], "source.reference");
  if (!j["fields"].is_object() || j["fields"].empty())
    throw SettingsError("settings field 'source.fields' must be an object naming each quantity and what the "
                        "reference gives for it (or \"not published\")");
  for (const auto& [key, value] : j["fields"].items())
    out.fields.emplace_back(key, text(value, "source.fields." + key));
  return out;
}

// A device preset limits the force at the tip to its device's peak; the
// device under the engine must be able to give that force along the tool,
// or the preset would feel like a weaker device than the one it names.
void check_preset_force(const EngineSettings& s) {
  if (!s.tip_force_saturation.enabled) return;
  if (s.tip_force_saturation.limit_N > s.device_limits.insertion_force_N)
    throw SettingsError("tip_force_saturation.limit_N is " + format_number(s.tip_force_saturation.limit_N) +
                        " N, but this device preset's device can give only " +
                        format_number(s.device_limits.insertion_force_N) +
                        " N along the tool (device_limits.insertion_force_N): the engine cannot make it feel "
                        "like the device named in source.device");
}

// Where `text` names the settings field `path` (a whole dotted name, not
// part of a longer one), and the number after it when it reads
// "path = number" (NaN when no number follows that mention).
std::vector<double> mentions_of(const std::string& text, const std::string& path) {
  auto word = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; };
  std::vector<double> out;
  for (std::size_t at = text.find(path); at != std::string::npos; at = text.find(path, at + 1)) {
    const std::size_t end = at + path.size();
    if ((at > 0 && (word(text[at - 1]) || text[at - 1] == '.')) || (end < text.size() && word(text[end]))) continue;
    std::size_t k = end;
    while (k < text.size() && text[k] == ' ') ++k;
    double value = std::numeric_limits<double>::quiet_NaN();
    if (k < text.size() && text[k] == '=') {
      ++k;
      while (k < text.size() && text[k] == ' ') ++k;
      double v = 0.0;
      const auto [ptr, ec] = std::from_chars(text.data() + k, text.data() + text.size(), v);
      if (ec == std::errc() && ptr != text.data() + k) value = v;
    }
    out.push_back(value);
  }
  return out;
}

// A device preset sets only what its source gives. Every number it sets
// away from the model's default, and every block it switches on, is named
// in a source.fields entry ("translation.friction.dynamic_level_N = 0.7",
// or, as the first presets wrote it, the field's name alone); a field a
// source entry names is in force, at the value the entry gives. The device
// under the engine (device_limits) and the transform's floor
// (min_moment_arm_m) are not the named device's and are exempt.
void check_preset_sourced(EngineSettings s, const SettingsSource& source) {
  std::vector<Block> blocks;
  std::vector<std::string> prefixes;
  for (Block& b : axis_blocks(AxisKind::kTranslation, s.translation)) {
    blocks.push_back(b);
    prefixes.push_back("translation.");
  }
  for (Block& b : axis_blocks(AxisKind::kRotation, s.rotation)) {
    blocks.push_back(b);
    prefixes.push_back("rotation.");
  }
  for (Block& b : engine_blocks(s)) {
    if (b.name == "device_limits") continue;
    blocks.push_back(b);
    prefixes.push_back("");
  }
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    const Block& b = blocks[i];
    const std::string block_path = prefixes[i] + b.name;
    const bool on = b.enabled == nullptr || *b.enabled;
    bool any_named = false;
    for (const Field& f : b.fields) {
      const std::string path = block_path + "." + f.key;
      bool named = false;
      for (const auto& [quantity, text] : source.fields) {
        const std::vector<double> mentions = mentions_of(text, path);
        if (mentions.empty()) continue;
        named = true;
        if (!on)
          throw SettingsError("source.fields." + quantity + " names " + path + ", but this device preset leaves '" +
                              block_path + "' off: a quantity its source gives is in force");
        for (double v : mentions)
          if (!std::isnan(v) && v != *f.value)
            throw SettingsError("source.fields." + quantity + " gives " + path + " = " + format_number(v) +
                                ", but this device preset sets it to " + format_number(*f.value));
      }
      any_named = any_named || named;
      // The ripple's period follows the cogging period unless given.
      const double default_value = f.key.starts_with("ripple_period_") ? *b.fields[1].value : f.default_value;
      if (on && !named && *f.value != default_value)
        throw SettingsError("settings field '" + path + "' is " + format_number(*f.value) +
                            " in this device preset, but no source.fields entry names it: every number a preset "
                            "sets comes from its source (write \"" + path + " = " + format_number(*f.value) +
                            "\" in the quantity it comes from)");
    }
    if (b.enabled != nullptr && *b.enabled && !any_named)
      throw SettingsError("settings block '" + block_path + "' is on in this device preset, but no source.fields "
                          "entry names any of its fields: a preset switches on only what its source gives");
  }
}

}  // namespace

std::vector<std::string> split_settings_field(std::string_view dotted) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  for (std::size_t dot; (dot = dotted.find('.', start)) != std::string_view::npos; start = dot + 1)
    parts.emplace_back(dotted.substr(start, dot - start));
  parts.emplace_back(dotted.substr(start));
  return parts;
}

const nlohmann::json* find_settings_field(const nlohmann::json& settings, std::string_view dotted) {
  const nlohmann::json* node = &settings;
  for (const std::string& key : split_settings_field(dotted)) {
    if (!node->is_object() || !node->contains(key)) return nullptr;
    node = &(*node)[key];
  }
  return node;
}

std::string dose_setting_name(std::string_view base, std::string_view field, double strength) {
  return std::string(base) + ", " + split_settings_field(field).back() + " = " + format_number<double>(strength);  // shortest round trip, as the protocol wrote it
}

NamedSettings settings_at_strength(const NamedSettings& base, std::string_view field, double strength) {
  nlohmann::json j = settings_to_json(base);
  // At another strength a device preset is no longer the device its source
  // describes: the copy drops the source (and so is no preset).
  j.erase("source");
  const std::vector<std::string> parts = split_settings_field(field);
  const nlohmann::json* leaf = find_settings_field(j, field);
  if (parts.size() < 2 || leaf == nullptr || !leaf->is_number())
    throw SettingsError(std::string(field) + " is not a numeric settings field of '" + base.name + "'");
  nlohmann::json* block = &j;
  for (std::size_t k = 0; k + 1 < parts.size(); ++k) block = &(*block)[parts[k]];
  if (block->contains("enabled")) (*block)["enabled"] = true;
  (*block)[parts.back()] = strength;
  const std::string name = dose_setting_name(base.name, field, strength);
  j["name"] = name;
  return settings_from_json(j, name);
}

std::string source_text(const SettingsSource& source) {
  std::string out = "Source: " + source.device + "\n  reference: " + source.reference + "\n";
  for (const auto& [quantity, what] : source.fields) out += "  " + quantity + ": " + what + "\n";
  return out;
}

NamedSettings settings_from_json(const json& j, const std::string& source) {
  try {
    NamedSettings out;
    out.engine = defaults();
    EngineSettings& s = out.engine;
    expect_object(j, "(top level)");
    std::vector<Block> top = engine_blocks(s);
    read_blocks(j, "", top,
                {"name", "description", "translation", "rotation", "min_moment_arm_m", "source"});
    if (j.contains("name")) {
      if (!j["name"].is_string()) throw SettingsError("settings field 'name' must be a string");
      out.name = j["name"].get<std::string>();
    }
    if (j.contains("description")) {
      if (!j["description"].is_string())
        throw SettingsError("settings field 'description' must be a string");
      out.description = j["description"].get<std::string>();
    }
    if (j.contains("min_moment_arm_m")) {
      Field f = moment_arm_field(s);
      if (!j["min_moment_arm_m"].is_number())
        throw SettingsError("settings field 'min_moment_arm_m' must be a number; " + range_text(f));
      *f.value = j["min_moment_arm_m"].get<double>();
      check_range("min_moment_arm_m", f, *f.value);
    }
    for (auto [kind, key] : {std::pair{AxisKind::kTranslation, "translation"},
                             std::pair{AxisKind::kRotation, "rotation"}}) {
      if (!j.contains(key)) continue;
      AxisSettings& a = kind == AxisKind::kTranslation ? s.translation : s.rotation;
      std::vector<Block> blocks = axis_blocks(kind, a);
      const json& axis_json = j[key];
      read_blocks(axis_json, key, blocks, {});
      // The ripple follows the cogging period unless given.
      if (axis_json.contains("cogging") &&
          !axis_json["cogging"].contains(blocks[1].fields[4].key)) {
        a.cogging.ripple_period = a.cogging.period;
      }
    }
    check_cross_fields(s);
    if (j.contains("source")) {
      out.source = read_source(j["source"]);
      check_preset_force(s);
      check_preset_sourced(s, *out.source);
    }
    return out;
  } catch (const SettingsError& e) {
    throw SettingsError(source + ": " + e.what());
  }
}

NamedSettings settings_from_json_text(std::string_view text, const std::string& source) {
  json j;
  try {
    j = parse_json_strict(text);
  } catch (const InputFileError& e) {  // syntax, depth, duplicate keys, numbers beyond a double
    throw SettingsError(source + ": " + e.what());
  }
  return settings_from_json(j, source);
}

NamedSettings load_settings_file(const std::filesystem::path& path) {
  std::string text;
  try {
    text = read_text_file(path, kMaxJsonFileBytes, "settings file");
  } catch (const InputFileError& e) {
    throw SettingsError(e.what());
  }
  return settings_from_json_text(text, path.string());
}

json settings_to_json(const NamedSettings& named) {
  EngineSettings s = named.engine;
  json out = json::object();
  out["name"] = named.name;
  if (!named.description.empty()) out["description"] = named.description;
  for (auto [kind, key] : {std::pair{AxisKind::kTranslation, "translation"},
                           std::pair{AxisKind::kRotation, "rotation"}}) {
    AxisSettings& a = kind == AxisKind::kTranslation ? s.translation : s.rotation;
    json axis = json::object();
    for (const Block& b : axis_blocks(kind, a)) axis[b.name] = block_to_json(b);
    out[key] = axis;
  }
  for (const Block& b : engine_blocks(s)) out[b.name] = block_to_json(b);
  out["min_moment_arm_m"] = s.min_moment_arm_m;
  if (named.source) {
    json fields = json::object();
    for (const auto& [quantity, what] : named.source->fields) fields[quantity] = what;
    out["source"] = {{"device", named.source->device}, {"reference", named.source->reference}, {"fields", fields}};
  }
  return out;
}

void validate_settings(const EngineSettings& settings) {
  EngineSettings s = settings;  // the tables need mutable access
  auto check = [](const std::string& prefix, std::vector<Block> blocks) {
    for (const Block& b : blocks) {
      // Disabled blocks may hold anything except non-finite garbage; enabled
      // ones must be in range.
      if (b.enabled && !*b.enabled) continue;
      for (const Field& f : b.fields) check_range(prefix + b.name + "." + f.key, f, *f.value);
    }
  };
  check("translation.", axis_blocks(AxisKind::kTranslation, s.translation));
  check("rotation.", axis_blocks(AxisKind::kRotation, s.rotation));
  check("", engine_blocks(s));
  Field arm = moment_arm_field(s);
  check_range("min_moment_arm_m", arm, *arm.value);
  check_cross_fields(s);
}

}  // namespace hapticlab

namespace hapticlab {

std::vector<SettingsFieldInfo> settings_field_reference() {
  EngineSettings s;
  std::vector<SettingsFieldInfo> out;
  auto rows = [&out](const std::string& prefix, const std::vector<Block>& blocks) {
    for (const Block& b : blocks)
      for (const Field& f : b.fields) out.push_back({prefix + b.name + "." + f.key, f.default_value, f.lo, f.hi, f.lo_exclusive});
  };
  rows("translation.", axis_blocks(AxisKind::kTranslation, s.translation));
  rows("rotation.", axis_blocks(AxisKind::kRotation, s.rotation));
  rows("", engine_blocks(s));
  const Field arm = moment_arm_field(s);
  out.push_back({arm.key, arm.default_value, arm.lo, arm.hi, arm.lo_exclusive});
  return out;
}

std::string settings_reference_markdown() {
  std::ostringstream md;
  md << "| field | default | allowed |\n| --- | --- | --- |\n";
  for (const SettingsFieldInfo& f : settings_field_reference()) {
    md << "| `" << f.path << "` | " << format_number(f.default_value) << " | " << (f.lo_exclusive ? "> " : ">= ")
       << format_number(f.lo) << ", <= " << format_number(f.hi) << " |\n";
  }
  return md.str();
}

}  // namespace hapticlab
