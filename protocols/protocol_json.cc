#include "protocols/protocol_json.h"

#include <algorithm>
#include <climits>
#include <cstdint>
#include <fstream>
#include <initializer_list>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/common/csv_format.h"
#include "core/io/input_file.h"
#include "protocols/protocol_error.h"
#include "protocols/safety_json.h"
#include "protocols/shown_json.h"

namespace hapticlab::protocols {
namespace {

using nlohmann::json;

// Reads one protocol document; every helper names the field path on error.
class Reader {
 public:
  Reader(std::string source, std::filesystem::path base_dir)
      : source_(std::move(source)), base_dir_(std::move(base_dir)) {}

  Protocol read(const json& j) {
    expect_object(j, "(top level)");
    check_keys(j, "", {"study", "description", "ve", "tasks", "repetitions", "settings", "participants", "design",
                       "seed", "training_trials", "safety", "null_settings", "dose"});
    Protocol p;
    p.study = as_string(require(j, "study", ""), "study");
    if (j.contains("description")) p.description = as_string(j["description"], "description");
    if (j.contains("ve")) {
      const std::string ve = j["ve"].is_string() ? j["ve"].get<std::string>() : "";
      if (ve == "simulated") p.ve = Ve::kSimulated;
      else if (ve == "external") p.ve = Ve::kExternal;
      else fail("ve", "is " + shown(j["ve"]) + ", but must be \"simulated\" (HapticLab's VE, the default) or "
                      "\"external\" (the lab's own VE, run through the study API)");
    }
    ve_ = p.ve;
    p.tasks = read_tasks(require(j, "tasks", ""), "tasks");
    read_repetitions(require(j, "repetitions", ""), p);
    read_settings(require(j, "settings", ""), p);
    if (j.contains("dose")) read_dose(j["dose"], p);
    const int default_training =
        j.contains("training_trials") ? as_int(j["training_trials"], "training_trials", 0, kMaxTrainingTrials) : 0;
    read_participants(require(j, "participants", ""), p, default_training);
    read_design(require(j, "design", ""), p);
    p.seed = as_seed(require(j, "seed", ""), "seed");
    if (j.contains("safety")) p.safety = safety_from_json(j["safety"], source_);
    if (j.contains("null_settings")) {
      p.null_settings = read_names(j["null_settings"], "null_settings");
      for (std::size_t i = 0; i < p.null_settings.size(); ++i)
        if (!p.find_setting(p.null_settings[i]))
          fail(index_path("null_settings", i), "is \"" + p.null_settings[i] + "\", but is not one of the settings");
    }
    validate_protocol(p, source_);
    return p;
  }

 private:
  [[noreturn]] void fail(const std::string& path, const std::string& message) const {
    throw ProtocolError(source_, path, message);
  }

  static std::string join(const std::string& parent, const std::string& key) {
    return parent.empty() ? key : parent + "." + key;
  }

  const json& require(const json& obj, const std::string& key, const std::string& parent) const {
    auto it = obj.find(key);
    if (it == obj.end()) fail(join(parent, key), "is missing, but is required");
    return *it;
  }

  void expect_object(const json& v, const std::string& path) const {
    if (!v.is_object()) fail(path, "is " + shown(v) + ", but must be an object");
  }

  void check_keys(const json& obj, const std::string& parent, std::initializer_list<std::string_view> allowed) const {
    for (const auto& [key, value] : obj.items()) {
      if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
        std::string list;
        for (auto a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
        fail(join(parent, key), "is not a known field; allowed here: " + list);
      }
    }
  }

  std::string as_string(const json& v, const std::string& path) const {
    if (!v.is_string()) fail(path, "is " + shown(v) + ", but must be a string");
    return v.get<std::string>();
  }

  const json& as_array(const json& v, const std::string& path) const {
    if (!v.is_array()) fail(path, "is " + shown(v) + ", but must be an array");
    return v;
  }

  int as_int(const json& v, const std::string& path, long long lo, long long hi,
             const std::string& why = "") const {
    const std::string rule = "must be a whole number >= " + std::to_string(lo) + " and <= " + std::to_string(hi) + why;
    if (!v.is_number_integer()) fail(path, "is " + shown(v) + ", but " + rule);
    // Unsigned values above LLONG_MAX are out of every range used here.
    if (v.is_number_unsigned() && v.get<std::uint64_t>() > static_cast<std::uint64_t>(hi)) {
      fail(path, "is " + shown(v) + ", but " + rule);
    }
    const long long x = v.get<long long>();
    if (x < lo || x > hi) fail(path, "is " + shown(v) + ", but " + rule);
    return static_cast<int>(x);
  }

  std::uint64_t as_seed(const json& v, const std::string& path) const {
    const std::string rule = "must be a whole number >= 0 and <= 18446744073709551615 (unsigned 64-bit)";
    if (v.is_number_unsigned()) return v.get<std::uint64_t>();
    // Parsed non-negative integers are unsigned; ones built in code may be
    // signed.
    if (v.is_number_integer() && v.get<long long>() >= 0) return static_cast<std::uint64_t>(v.get<long long>());
    fail(path, "is " + shown(v) + ", but " + rule);
  }

  Task as_task(const json& v, const std::string& path) const {
    if (ve_ == Ve::kSimulated) {
      const std::string name = v.is_string() ? v.get<std::string>() : "";
      if (auto t = task_from_name(name)) return *t;
      fail(path, "is " + shown(v) + ", but must be one of \"dissection\", \"clip\" (the simulated VE's tasks; "
                 "a lab's own task needs \"ve\": \"external\")");
    }
    const std::string name = as_string(v, path);
    if (auto problem = task_name_problem(name, ve_)) fail(path, "is " + shown(v) + ", which " + *problem);
    return Task(name);
  }

  std::vector<Task> read_tasks(const json& v, const std::string& path) const {
    std::vector<Task> tasks;
    const json& arr = as_array(v, path);
    for (std::size_t i = 0; i < arr.size(); ++i) tasks.push_back(as_task(arr[i], index_path(path, i)));
    return tasks;
  }

  void read_repetitions(const json& v, Protocol& p) const {
    expect_object(v, "repetitions");
    for (const auto& [key, value] : v.items()) {
      if (ve_ == Ve::kSimulated && !task_from_name(key))
        fail("repetitions." + key, "is not a task; tasks are \"dissection\", \"clip\"");
      const Task task(key);
      if (std::find(p.tasks.begin(), p.tasks.end(), task) == p.tasks.end()) {
        fail("repetitions." + key, "is given, but \"" + key + "\" is not in tasks");
      }
      p.repetitions[task] = as_int(value, "repetitions." + key, 1, kMaxRepetitions, " (repetitions of every setting)");
    }
    for (const Task& t : p.tasks) {
      if (!v.contains(std::string(task_name(t)))) {
        fail("repetitions." + std::string(task_name(t)), "is missing, but every task in tasks needs its repetitions");
      }
    }
  }

  // One entry of "settings" (or dose.settings): a file path, relative to
  // the protocol's folder, or an inline settings object.
  ProtocolSetting read_setting(const json& item, const std::string& path) const {
    ProtocolSetting ps;
    try {
      if (item.is_string()) {
        ps.source = item.get<std::string>();
        std::filesystem::path file(ps.source);
        if (file.is_relative()) file = base_dir_ / file;
        ps.settings = load_settings_file(file);
      } else if (item.is_object()) {
        ps.source = "inline";
        ps.settings = settings_from_json(item, source_ + " " + path);
      } else {
        fail(path, "is " + shown(item) + ", but must be a settings file path (string) or a settings object");
      }
    } catch (const SettingsError& e) {
      fail(path, "(" + shown(item) + ") is not valid settings: " + e.what());
    }
    return ps;
  }

  void read_settings(const json& v, Protocol& p) const {
    const json& arr = as_array(v, "settings");
    for (std::size_t i = 0; i < arr.size(); ++i) p.settings.push_back(read_setting(arr[i], index_path("settings", i)));
  }

  // "dose": one degradation at several strengths (issue 19 §4). Each
  // strength is a setting of its own, the base settings with `field` set to
  // it and its block switched on, named "<base name>, <key> = <strength>";
  // the schedule randomizes them like any other setting. The control stays
  // in "settings".
  void read_dose(const json& v, Protocol& p) const {
    expect_object(v, "dose");
    check_keys(v, "dose", {"settings", "field", "strengths"});
    const ProtocolSetting base = read_setting(require(v, "settings", "dose"), "dose.settings");
    const std::string field = as_string(require(v, "field", "dose"), "dose.field");
    const json base_json = settings_to_json(base.settings);
    const std::vector<std::string> parts = split_settings_field(field);
    const json* leaf = find_settings_field(base_json, field);
    if (parts.size() < 2 || leaf == nullptr || !leaf->is_number())
      fail("dose.field", "is " + shown(v["field"]) + ", but must be a numeric settings field, e.g. "
                         "\"translation.friction.dynamic_level_N\" (`hapticlab settings reference` lists them)");
    const json& arr = as_array(require(v, "strengths", "dose"), "dose.strengths");
    if (arr.size() < 2)
      fail("dose.strengths", "has " + std::to_string(arr.size()) + " strength(s), but a dose-response needs at least 2");
    for (std::size_t i = 0; i < arr.size(); ++i) {
      const std::string path = index_path("dose.strengths", i);
      if (!arr[i].is_number()) fail(path, "is " + shown(arr[i]) + ", but must be a number");
      const double x = arr[i].get<double>();
      if (i > 0 && !(x > arr[i - 1].get<double>()))
        fail(path, "is " + shown(arr[i]) + ", but must be greater than " + index_path("dose.strengths", i - 1) + " (" +
                       shown(arr[i - 1]) + "): strengths are listed in increasing order, each once");
      json j = base_json;
      json* block = &j;
      for (std::size_t k = 0; k + 1 < parts.size(); ++k) block = &(*block)[parts[k]];
      if (block->contains("enabled")) (*block)["enabled"] = true;
      (*block)[parts.back()] = x;
      j["name"] = dose_setting_name(base.settings.name, field, x);
      ProtocolSetting ps;
      ps.source = (base.source == "inline" ? std::string("inline") : base.source) + ", " + field + " = " +
                  format_number(x);
      try {
        ps.settings = settings_from_json(j, source_ + " " + path);
      } catch (const SettingsError& e) {
        fail(path, "(" + shown(arr[i]) + ") is not a valid " + field + ": " + e.what());
      }
      p.settings.push_back(std::move(ps));
    }
  }

  void read_participants(const json& v, Protocol& p, int default_training) const {
    const json& arr = as_array(v, "participants");
    for (std::size_t i = 0; i < arr.size(); ++i) {
      const std::string path = index_path("participants", i);
      const json& item = arr[i];
      ParticipantSpec ps;
      ps.tasks = p.tasks;
      ps.training_trials = default_training;
      // A bare string is shorthand for {"code": ...}.
      if (item.is_string()) {
        ps.code = item.get<std::string>();
        if (auto problem = participant_code_problem(ps.code)) fail(path, "is " + shown(item) + ", which " + *problem);
      } else if (item.is_object()) {
        check_keys(item, path, {"code", "tasks", "training_trials"});
        ps.code = as_string(require(item, "code", path), path + ".code");
        if (item.contains("tasks")) ps.tasks = read_tasks(item["tasks"], path + ".tasks");
        if (item.contains("training_trials")) {
          ps.training_trials = as_int(item["training_trials"], path + ".training_trials", 0, kMaxTrainingTrials);
        }
      } else {
        fail(path, "is " + shown(item) + ", but must be a participant code (string) or an object with \"code\"");
      }
      p.participants.push_back(std::move(ps));
    }
  }

  std::vector<std::string> read_names(const json& v, const std::string& path) const {
    std::vector<std::string> names;
    const json& arr = as_array(v, path);
    for (std::size_t i = 0; i < arr.size(); ++i) names.push_back(as_string(arr[i], index_path(path, i)));
    return names;
  }

  void read_design(const json& v, Protocol& p) const {
    expect_object(v, "design");
    const std::string type = as_string(require(v, "type", "design"), "design.type");
    Design& d = p.design;
    if (type == "complete") {
      d.type = DesignType::kComplete;
      check_keys(v, "design", {"type"});
    } else if (type == "incomplete") {
      d.type = DesignType::kIncomplete;
      check_keys(v, "design", {"type", "required", "k"});
      d.required = read_names(require(v, "required", "design"), "design.required");
      const long long optional =
          std::max(0LL, static_cast<long long>(p.settings.size()) - static_cast<long long>(d.required.size()));
      d.k = as_int(require(v, "k", "design"), "design.k", 0, optional,
                   " (the number of settings not in design.required)");
    } else if (type == "explicit") {
      d.type = DesignType::kExplicit;
      check_keys(v, "design", {"type", "assignments"});
      const json& a = require(v, "assignments", "design");
      expect_object(a, "design.assignments");
      for (const auto& [code, names] : a.items()) {
        d.assignments[code] = read_names(names, "design.assignments." + code);
      }
    } else {
      fail("design.type", "is \"" + type + "\", but must be one of \"complete\", \"incomplete\", \"explicit\"");
    }
  }

  std::string source_;
  std::filesystem::path base_dir_;
  Ve ve_ = Ve::kSimulated;  // the protocol's, once read: how task names are checked
};

}  // namespace

Protocol protocol_from_json(const json& j, const std::filesystem::path& base_dir, const std::string& source) {
  return Reader(source, base_dir).read(j);
}

Protocol protocol_from_json_text(std::string_view text, const std::filesystem::path& base_dir,
                                 const std::string& source) {
  json j;
  try {
    j = parse_json_strict(text);
  } catch (const InputFileError& e) {  // syntax, depth, duplicate keys, numbers beyond a double
    throw ProtocolError(source, "(file)", std::string("is refused: ") + e.what());
  }
  return protocol_from_json(j, base_dir, source);
}

std::string read_protocol_text(const std::filesystem::path& path) {
  try {
    return read_text_file(path, kMaxJsonFileBytes, "protocol file");
  } catch (const InputFileError& e) {
    throw ProtocolError(path.string(), "(file)", std::string("cannot be read: ") + e.what());
  }
}

Protocol load_protocol_file(const std::filesystem::path& path) {
  return protocol_from_json_text(read_protocol_text(path), path.parent_path(), path.string());
}

}  // namespace hapticlab::protocols
