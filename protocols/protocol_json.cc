#include "protocols/protocol_json.h"

#include <algorithm>
#include <climits>
#include <cstdint>
#include <fstream>
#include <initializer_list>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/common/csv_format.h"
#include "core/common/input_file.h"
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

  StaircaseSpec staircase_spec(const json& v, const std::string& only_task) {
    only_task_ = only_task;
    return read_staircase_spec(v, nullptr);
  }

  Protocol read(const json& j) {
    expect_object(j, "(top level)");
    check_keys(j, "", {"study", "description", "ve", "tasks", "repetitions", "settings", "participants", "design",
                       "seed", "training_trials", "safety", "rate_tolerance_fraction", "null_settings", "dose",
                       "staircase", "groups", "stratify_by", "phases"});
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
    const bool grouped = j.contains("groups") || j.contains("phases");
    if (grouped) refuse_within_fields(j);
    else read_repetitions(require(j, "repetitions", ""), p);
    read_settings(require(j, "settings", ""), p);
    if (j.contains("dose")) read_dose(j["dose"], p);
    const int default_training =
        j.contains("training_trials") ? as_int(j["training_trials"], "training_trials", 0, kMaxTrainingTrials) : 0;
    read_participants(require(j, "participants", ""), p, default_training);
    if (grouped) read_transfer(j, p);
    else read_design(require(j, "design", ""), p);
    p.seed = as_seed(require(j, "seed", ""), "seed");
    if (j.contains("safety")) p.safety = safety_from_json(j["safety"], source_);
    if (j.contains("rate_tolerance_fraction"))
      p.rate_tolerance_fraction = as_double(j["rate_tolerance_fraction"], "rate_tolerance_fraction",
                                            kMinRateToleranceFraction, kMaxRateToleranceFraction, false);
    if (j.contains("null_settings")) {
      p.null_settings = read_names(j["null_settings"], "null_settings");
      for (std::size_t i = 0; i < p.null_settings.size(); ++i) {
        if (!p.find_setting(p.null_settings[i]))
          fail(index_path("null_settings", i), "is \"" + p.null_settings[i] + "\", but is not one of the settings");
        // As in tasks and required: a name twice is a slip, whose second
        // copy a reader would look for in vain.
        for (std::size_t k = 0; k < i; ++k)
          if (p.null_settings[k] == p.null_settings[i])
            fail(index_path("null_settings", i), "is \"" + p.null_settings[i] + "\", the same as null_settings[" +
                                                     std::to_string(k) + "]; name each setting once");
      }
    }
    if (j.contains("staircase")) {
      if (j.contains("dose")) fail("staircase", "is given with \"dose\", but a protocol has one or the other");
      read_staircase(j["staircase"], p);
    }
    validate_protocol(p, source_);
    return p;
  }

  // What a stored group design's progress needs (group_design_from_protocol_text):
  // the study, tasks, participants, groups, phases and seed; not the
  // settings, which are in the database (checked when the study was made).
  Protocol read_group_design(const json& j) {
    Protocol p;
    expect_object(j, "(top level)");
    p.study = as_string(require(j, "study", ""), "study");
    if (j.contains("ve") && j["ve"] == "external") p.ve = Ve::kExternal;
    ve_ = p.ve;
    p.tasks = read_tasks(require(j, "tasks", ""), "tasks");
    read_participants(require(j, "participants", ""), p, 0);
    read_transfer(j, p);
    p.seed = as_seed(require(j, "seed", ""), "seed");
    return p;
  }

  // The rule of a "staircase" block; `p` (when given) is the protocol read
  // so far, for the checks that need its tasks and settings.
  StaircaseSpec read_staircase_spec(const json& v, const Protocol* p) const {
    expect_object(v, "staircase");
    check_keys(v, "staircase", {"settings", "field", "task", "measure", "change", "direction", "baseline", "start",
                                "step", "min", "max", "down", "reversals", "max_trials"});
    StaircaseSpec s;
    s.field = as_string(require(v, "field", "staircase"), "staircase.field");
    if (v.contains("task")) {
      s.task = as_string(v["task"], "staircase.task");
    } else if (p != nullptr && p->tasks.size() == 1) {
      s.task = std::string(task_name(p->tasks.front()));
    } else if (p == nullptr && !only_task_.empty()) {
      s.task = only_task_;
    } else {
      fail("staircase.task", "is missing, but the protocol has several tasks: name the one the staircase runs");
    }
    if (p != nullptr && std::none_of(p->tasks.begin(), p->tasks.end(),
                                     [&](const Task& t) { return task_name(t) == s.task; }))
      fail("staircase.task", "is \"" + s.task + "\", but is not one of the protocol's tasks");
    s.measure = as_string(require(v, "measure", "staircase"), "staircase.measure");
    if (std::find(kStaircaseMeasures.begin(), kStaircaseMeasures.end(), s.measure) == kStaircaseMeasures.end()) {
      std::string list;
      for (auto m : kStaircaseMeasures) list += (list.empty() ? "" : ", ") + std::string(m);
      fail("staircase.measure", "is " + shown(v["measure"]) + ", but must be one of " + list);
    }
    s.change = as_double(require(v, "change", "staircase"), "staircase.change", 0.0, 10.0, true);
    if (v.contains("direction")) {
      const std::string d = as_string(v["direction"], "staircase.direction");
      if (d == "increase") s.direction = ChangeDirection::kIncrease;
      else if (d == "decrease") s.direction = ChangeDirection::kDecrease;
      else if (d == "either") s.direction = ChangeDirection::kEither;
      else fail("staircase.direction", "is " + shown(v["direction"]) + ", but must be \"increase\", \"decrease\" or \"either\"");
    }
    // Without a baseline there is nothing for "changed" to be measured from.
    if (!v.contains("baseline"))
      fail("staircase.baseline", "is missing, but a staircase needs a baseline: the name of the setting whose "
                                 "trials give each participant's reference value (e.g. \"High Fidelity\")");
    s.baseline = as_string(v["baseline"], "staircase.baseline");
    if (p != nullptr && !p->find_setting(s.baseline)) {
      std::string names;
      for (const ProtocolSetting& ps : p->settings) names += (names.empty() ? "\"" : ", \"") + ps.settings.name + "\"";
      fail("staircase.baseline", "is \"" + s.baseline + "\", but is not one of the settings (" + names +
                                     "): the baseline's trials must be in every participant's schedule");
    }
    s.min = as_double(require(v, "min", "staircase"), "staircase.min", -1e12, 1e12, false);
    s.max = as_double(require(v, "max", "staircase"), "staircase.max", -1e12, 1e12, false);
    if (!(s.max > s.min)) fail("staircase.max", "is " + shown(v["max"]) + ", but must be greater than staircase.min (" + shown(v["min"]) + ")");
    s.start = as_double(require(v, "start", "staircase"), "staircase.start", s.min, s.max, false);
    s.step = as_double(require(v, "step", "staircase"), "staircase.step", 0.0, s.max - s.min, true);
    if (v.contains("down")) s.down = as_int(v["down"], "staircase.down", 1, 3);
    if (v.contains("reversals")) s.reversals = as_int(v["reversals"], "staircase.reversals", 4, 30);
    if (s.reversals % 2 != 0)
      fail("staircase.reversals", "is " + shown(v["reversals"]) + ", but must be even: the threshold averages as "
                                  "many peaks as valleys");
    if (v.contains("max_trials")) s.max_trials = as_int(v["max_trials"], "staircase.max_trials", 5, 200);
    if (s.max_trials <= s.reversals)
      fail("staircase.max_trials", "is " + std::to_string(s.max_trials) + ", but must be greater than "
                                   "staircase.reversals (" + std::to_string(s.reversals) + ")");
    return s;
  }

  // The field a dose or staircase varies must be a number of its settings.
  void check_numeric_field(const NamedSettings& base, const json& field, const std::string& path) const {
    const json base_json = settings_to_json(base);
    const json* leaf = field.is_string() ? find_settings_field(base_json, field.get<std::string>()) : nullptr;
    if (leaf == nullptr || !leaf->is_number() || split_settings_field(field.get<std::string>()).size() < 2)
      fail(path, "is " + shown(field) + ", but must be a numeric settings field, e.g. "
                 "\"translation.friction.dynamic_level_N\" (`hapticlab settings reference` lists them)");
  }

  void read_staircase(const json& v, Protocol& p) const {
    ProtocolStaircase st;
    st.spec = read_staircase_spec(v, &p);
    st.base = read_setting(require(v, "settings", "staircase"), "staircase.settings");
    check_numeric_field(st.base.settings, v["field"], "staircase.field");
    for (const ProtocolSetting& ps : p.settings)
      if (setting_name_key(ps.settings.name) == setting_name_key(st.base.settings.name))
        fail("staircase.settings", "is named \"" + st.base.settings.name + "\", like the setting \"" +
                                       ps.settings.name + "\" (ignoring case, spaces, punctuation and accents); "
                                       "give it a name of its own");
    // Both ends must be strengths the settings accept.
    for (const char* end : {"min", "max"}) {
      const double x = end == std::string("min") ? st.spec.min : st.spec.max;
      try {
        settings_at_strength(st.base.settings, st.spec.field, x);
      } catch (const SettingsError& e) {
        fail(std::string("staircase.") + end, "(" + shown(v[end]) + ") is not a valid " + st.spec.field + ": " + e.what());
      }
    }
    // Every participant needs the baseline's trials.
    const std::string& b = st.spec.baseline;
    if (p.design.type == DesignType::kIncomplete &&
        std::find(p.design.required.begin(), p.design.required.end(), b) == p.design.required.end())
      fail("staircase.baseline", "is \"" + b + "\", but is not in design.required: every participant needs the "
                                 "baseline's trials");
    for (const auto& [code, names] : p.design.assignments)
      if (std::find(names.begin(), names.end(), b) == names.end())
        fail("staircase.baseline", "is \"" + b + "\", but design.assignments." + code + " does not give it: every "
                                   "participant needs the baseline's trials");
    p.staircase = std::move(st);
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

  // A number in [lo, hi] (lo excluded when lo_exclusive).
  double as_double(const json& v, const std::string& path, double lo, double hi, bool lo_exclusive) const {
    const std::string rule = std::string("must be a number ") + (lo_exclusive ? "> " : ">= ") + format_number(lo) +
                             " and <= " + format_number(hi);
    if (!v.is_number()) fail(path, "is " + shown(v) + ", but " + rule);
    const double x = v.get<double>();
    if ((lo_exclusive ? !(x > lo) : !(x >= lo)) || !(x <= hi)) fail(path, "is " + shown(v) + ", but " + rule);
    return x;
  }

  const json& as_array(const json& v, const std::string& path) const {
    if (!v.is_array()) fail(path, "is " + shown(v) + ", but must be an array");
    return v;
  }

  int as_int(const json& v, const std::string& path, long long lo, long long hi,
             const std::string& why = "") const {
    const std::string rule = "must be a whole number >= " + std::to_string(lo) + " and <= " + std::to_string(hi) + why;
    // 2.0 and 1e2 are whole numbers to a reader; the rule is about how
    // they are written (a count is read as an integer, not rounded).
    if (v.is_number_float()) {
      fail(path, "is " + shown(v) + ", but " + rule + ", written without a decimal point or exponent");
    }
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
    // A whole number above 2^64 - 1 is read as a double ("is
    // 1.8446744073709552e+19" for 2^64): said as what it is.
    if (v.is_number_float() && v.get<double>() >= 0x1p64)
      fail(path, "is larger than 18446744073709551615, but " + rule);
    if (v.is_number_float()) fail(path, "is " + shown(v) + ", but " + rule + ", written without a decimal point or exponent");
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
    check_numeric_field(base.settings, v["field"], "dose.field");
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
      ProtocolSetting ps;
      ps.source = (base.source == "inline" ? std::string("inline") : base.source) + ", " + field + " = " +
                  format_number(x);
      try {
        ps.settings = settings_at_strength(base.settings, field, x);
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
        check_keys(item, path, {"code", "tasks", "training_trials", "attributes"});
        if (item.contains("attributes")) ps.attributes = read_attributes(item["attributes"], path + ".attributes");
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

  std::map<std::string, std::string> read_attributes(const json& v, const std::string& path) const {
    expect_object(v, path);
    std::map<std::string, std::string> out;
    for (const auto& [key, value] : v.items()) {
      const std::string text = as_string(value, path + "." + key);
      if (text.empty() || text.size() > kMaxGroupNameLength)
        fail(path + "." + key, "is " + shown(value) + ", but must be 1.." + std::to_string(kMaxGroupNameLength) + " bytes");
      out[key] = text;
    }
    return out;
  }

  // A between-group design's trials all come from its phases.
  void refuse_within_fields(const json& j) const {
    if (!j.contains("groups")) fail("groups", "is missing, but \"phases\" is given: a phased protocol randomizes its "
                                             "participants to groups (one group is allowed)");
    if (!j.contains("phases")) fail("phases", "is missing, but \"groups\" is given: a group design needs its phases");
    for (const char* key : {"design", "repetitions", "dose", "staircase"})
      if (j.contains(key))
        fail(key, "is given with \"groups\", but a group design's trials come from its phases; remove \"" +
                      std::string(key) + "\"");
  }

  void read_transfer(const json& j, Protocol& p) const {
    TransferDesign d;
    const json& groups = as_array(j["groups"], "groups");
    for (std::size_t i = 0; i < groups.size(); ++i) {
      const std::string path = index_path("groups", i);
      expect_object(groups[i], path);
      check_keys(groups[i], path, {"name", "training", "size"});
      Group g;
      g.name = as_string(require(groups[i], "name", path), path + ".name");
      const json& training = require(groups[i], "training", path);
      if (!training.is_null()) g.training_setting = as_string(training, path + ".training");
      if (groups[i].contains("size")) g.size = as_int(groups[i]["size"], path + ".size", 0, 1000000);
      d.groups.push_back(std::move(g));
    }
    if (j.contains("stratify_by")) {
      d.stratify_by = as_string(j["stratify_by"], "stratify_by");
      if (d.stratify_by.empty()) fail("stratify_by", "is empty, but must name a participant attribute (or be left out)");
    }
    const json& phases = as_array(j["phases"], "phases");
    for (std::size_t i = 0; i < phases.size(); ++i) {
      const std::string path = index_path("phases", i);
      expect_object(phases[i], path);
      check_keys(phases[i], path, {"phase", "setting", "sessions", "trials", "min_gap_h"});
      Phase ph;
      const json& kind = require(phases[i], "phase", path);
      const auto k = phase_kind_from_name(kind.is_string() ? kind.get<std::string>() : "");
      if (!k) fail(path + ".phase", "is " + shown(kind) + ", but must be one of \"pre_test\", \"training\", "
                                    "\"post_test\", \"retention\"");
      ph.kind = *k;
      if (phases[i].contains("setting")) ph.setting = as_string(phases[i]["setting"], path + ".setting");
      if (phases[i].contains("sessions")) ph.sessions = as_int(phases[i]["sessions"], path + ".sessions", 0, 1000000);
      const json& trials = require(phases[i], "trials", path);
      expect_object(trials, path + ".trials");
      for (const auto& [task, n] : trials.items())
        ph.trials[task] = as_int(n, path + ".trials." + task, 1, kMaxPhaseTrials, " (trials per sitting)");
      if (phases[i].contains("min_gap_h"))
        ph.min_gap_h = as_double(phases[i]["min_gap_h"], path + ".min_gap_h", 0.0, kMaxMinGap_h, false);
      else if (ph.kind == PhaseKind::kRetention)
        fail(path + ".min_gap_h", "is missing, but the retention test needs its delay (hours after the post-test)");
      d.phases.push_back(std::move(ph));
    }
    p.transfer = std::move(d);
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
  std::string only_task_;    // a stored protocol's task when it has one, for staircase_spec
};

}  // namespace

double rate_tolerance_from_protocol_text(std::string_view text, const std::string& source) {
  const json j = json::parse(text);
  const auto it = j.find("rate_tolerance_fraction");
  if (it == j.end()) return RateCheck::kDefaultToleranceFraction;
  if (!it->is_number() || !(it->get<double>() >= kMinRateToleranceFraction) ||
      !(it->get<double>() <= kMaxRateToleranceFraction))
    throw ProtocolError(source, "rate_tolerance_fraction",
                        "is " + it->dump() + ", but must be a number >= 0.001 and <= 0.5");
  return it->get<double>();
}

std::optional<StaircaseSpec> staircase_from_protocol_text(std::string_view text, const std::string& source) {
  json j;
  try {
    j = parse_json_strict(text);
  } catch (const InputFileError& e) {
    throw ProtocolError(source, "(file)", std::string("is refused: ") + e.what());
  }
  if (!j.is_object() || !j.contains("staircase")) return std::nullopt;
  const json* tasks = j.contains("tasks") ? &j["tasks"] : nullptr;
  const std::string only_task =
      tasks != nullptr && tasks->is_array() && tasks->size() == 1 && (*tasks)[0].is_string() ? (*tasks)[0].get<std::string>() : "";
  return Reader(source, {}).staircase_spec(j["staircase"], only_task);
}

std::optional<Protocol> group_design_from_protocol_text(std::string_view text, const std::string& source) {
  json j;
  try {
    j = parse_json_strict(text);
  } catch (const InputFileError& e) {
    throw ProtocolError(source, "(file)", std::string("is refused: ") + e.what());
  }
  if (!j.is_object() || !j.contains("groups") || !j.contains("phases")) return std::nullopt;
  return Reader(source, {}).read_group_design(j);
}

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
