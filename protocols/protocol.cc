#include "protocols/protocol.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <set>

#include "core/common/utf8.h"
#include "protocols/protocol_error.h"
#include "protocols/transfer_rules.h"

namespace hapticlab::protocols {
namespace {

std::string in_quotes(std::string_view s) { return "\"" + std::string(s) + "\""; }

// `s` with every byte outside printable ASCII as \xHH, so that names that
// look alike on a terminal are told apart in the message.
std::string escaped(std::string_view s) {
  std::string out;
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (u >= 0x20 && u < 0x7F) {
      out += c;
    } else {
      char hex[5];
      std::snprintf(hex, sizeof hex, "\\x%02X", u);
      out += hex;
    }
  }
  return out;
}

// Checks one list of setting names (design.required or one explicit
// assignment): every name known, none twice.
void check_setting_names(const Protocol& p, const std::vector<std::string>& names,
                         const std::string& path, const std::string& source) {
  std::set<std::string> seen;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (!p.find_setting(names[i])) {
      std::string known;
      for (const auto& s : p.settings) known += (known.empty() ? "" : ", ") + in_quotes(s.settings.name);
      throw ProtocolError(source, index_path(path, i),
                          "is " + in_quotes(names[i]) + ", but must be the name of one of the protocol's settings: " +
                              known);
    }
    if (!seen.insert(names[i]).second) {
      throw ProtocolError(source, index_path(path, i),
                          "is " + in_quotes(names[i]) + ", which is already listed; each setting at most once");
    }
  }
}

// A staircase protocol's comparison is the staircase: its schedule may be
// the baseline alone.
void check_enough_settings(std::size_t count, const std::string& path, const std::string& what,
                           const std::string& source, bool staircase) {
  if (staircase && count >= 1) return;
  if (count < 2) {
    throw ProtocolError(source, path,
                        "gives " + what + " " + std::to_string(count) +
                            " setting(s), but must give at least 2: a within-subject comparison needs two, "
                            "and with one every trial would repeat the same setting");
  }
}

}  // namespace

std::string_view ve_name(Ve ve) { return ve == Ve::kExternal ? "external" : "simulated"; }

std::string_view task_name(const Task& task) { return task.name(); }

std::optional<Task> task_from_name(std::string_view name) {
  for (const Task* t : {&Task::kDissection, &Task::kClip}) {
    if (t->name() == name) return *t;
  }
  return std::nullopt;
}

namespace {

// A byte below 0x20 or 0x7F, or a C1 control (U+0080..U+009F), which no
// table shows: "A\u0000B" printed as "A", "A\nB" across two lines.
bool has_control_character(std::string_view text) {
  for (std::size_t i = 0; i < text.size();) {
    const auto [c, n] = utf8_char_at(text, i);
    if (c < 0x20 || (c >= 0x7F && c <= 0x9F)) return true;
    i += n;
  }
  return false;
}

}  // namespace

std::optional<std::string> task_name_problem(std::string_view name, Ve ve) {
  if (ve == Ve::kSimulated) {
    if (task_from_name(name)) return std::nullopt;
    return "is not a task of the simulated VE; with \"ve\": \"simulated\" (the default) a task must be one of "
           "\"dissection\", \"clip\", and a lab's own task needs \"ve\": \"external\"";
  }
  const std::string rule = "a task name must be 1 to " + std::to_string(kMaxTaskNameLength) +
                           " bytes of printable text without leading or trailing spaces";
  if (name.empty() || name.size() > kMaxTaskNameLength)
    return "has " + std::to_string(name.size()) + " bytes, but " + rule;
  if (has_control_character(name)) return "contains a control character, but " + rule;
  if (name.front() == ' ' || name.back() == ' ') return "begins or ends with a space, but " + rule;
  return std::nullopt;
}

std::string staircase_base_row_name(std::string_view base_name) {
  return std::string(kStaircaseBasePrefix) + std::string(base_name);
}

namespace {

bool unicode_space(char32_t c) {
  return c == 0x00A0 || c == 0x1680 || (c >= 0x2000 && c <= 0x200D) || c == 0x2028 || c == 0x2029 ||
         c == 0x202F || c == 0x205F || c == 0x2060 || c == 0x3000 || c == 0xFEFF;
}

// U+00C0..U+00FF as the letter they are written with, '\0' for the two
// signs among them (multiplication, division).
constexpr char kLatin1Base[] = "aaaaaaaceeeeiiiidnooooo\0ouuuuytsaaaaaaaceeeeiiiidnooooo\0ouuuuyty";
// U+0100..U+017F (Latin Extended-A: the letters of Central and Eastern
// European names, "Řeháček", "Łódź") likewise, upper and lower case alike;
// '\0' for the ligatures ĳ and œ, kra, ŉ and eng, which stay as written.
constexpr char kLatinExtendedABase[] =
    "aaaaaaccccccccddddeeeeeeeeeegggggggghhhhiiiiiiiiii\0\0jjkk\0llllllllllnnnnnn\0\0\0oooooo\0\0rrrrrrssssssss"
    "ttttttuuuuuuuuuuuuwwyyyzzzzzzs";
static_assert(sizeof kLatinExtendedABase == 0x80 + 1, "one letter for each of U+0100..U+017F");


}  // namespace

std::string setting_name_key(std::string_view name) {
  std::string key;
  bool pending_gap = false;
  const auto add = [&](std::string_view text) {
    if (pending_gap && !key.empty()) key += '_';
    pending_gap = false;
    key += text;
  };
  for (std::size_t i = 0; i < name.size();) {
    const auto [c, n] = utf8_char_at(name, i);
    if (c < 0x80) {
      const bool digit_next = i + 1 < name.size() && std::isdigit(static_cast<unsigned char>(name[i + 1]));
      // A sign before a number and a decimal point within one are part of
      // it: "Delay +20 ms" and "Delay -20 ms", "f = 0.5" and "f = 05" are
      // different names.
      const bool numeric = ((c == '+' || c == '-') && digit_next) ||
                           (c == '.' && digit_next && !key.empty() && !pending_gap && std::isdigit(key.back()));
      if (std::isalnum(static_cast<int>(c)) || numeric) {
        const char lower = static_cast<char>(std::tolower(static_cast<int>(c)));
        add(std::string_view(&lower, 1));
      } else {
        pending_gap = true;
      }
    } else if (unicode_space(c)) {
      pending_gap = true;
    } else if (c >= 0x0300 && c <= 0x036F) {
      // a combining accent: the letter before it stands for both
    } else if (c >= 0x00C0 && c <= 0x00FF && kLatin1Base[c - 0x00C0] != '\0') {
      add(std::string_view(&kLatin1Base[c - 0x00C0], 1));
    } else if (c >= 0x0100 && c <= 0x017F && kLatinExtendedABase[c - 0x0100] != '\0') {
      add(std::string_view(&kLatinExtendedABase[c - 0x0100], 1));
    } else {
      add(name.substr(i, n));
    }
    i += n;
  }
  return key;
}

std::string control_name_key(std::string_view name) {
  std::string out;
  for (char c : name) {
    if (std::isalnum(static_cast<unsigned char>(c))) {
      out += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    } else if (!out.empty() && out.back() != '_') {
      out += '_';
    }
  }
  while (!out.empty() && out.back() == '_') out.pop_back();
  return out;
}

std::optional<std::size_t> Protocol::find_setting(std::string_view name) const {
  for (std::size_t i = 0; i < settings.size(); ++i) {
    if (settings[i].settings.name == name) return i;
  }
  return std::nullopt;
}

std::optional<std::string> participant_code_problem(std::string_view code) {
  const std::string rule = "must be a pseudonymous code of 1 to " + std::to_string(kMaxCodeLength) +
                           " letters, digits, '_' or '-' (codes only, never names)";
  if (code.find(' ') != std::string_view::npos) {
    return "contains a space and looks like a person's name; it " + rule;
  }
  if (code.empty() || code.size() > kMaxCodeLength) return "has " + std::to_string(code.size()) +
                                                           " characters, but " + rule;
  for (char c : code) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '-';
    if (!ok) return "contains a character other than letters, digits, '_' or '-'; it " + rule;
  }
  return std::nullopt;
}

namespace {

// The within-participant design: which settings each participant gets.
void validate_design(const Protocol& p, const std::set<std::string>& codes, const std::string& source) {
  const Design& d = p.design;
  switch (d.type) {
    case DesignType::kComplete:
      break;
    case DesignType::kIncomplete: {
      check_setting_names(p, d.required, "design.required", source);
      const int optional = static_cast<int>(p.settings.size() - d.required.size());
      if (d.k < 0 || d.k > optional) {
        throw ProtocolError(source, "design.k",
                            "is " + std::to_string(d.k) + ", but must be >= 0 and <= " + std::to_string(optional) +
                                " (the number of settings not in design.required)");
      }
      check_enough_settings(d.required.size() + static_cast<std::size_t>(d.k), "design",
                            "each participant", source, p.staircase.has_value());
      break;
    }
    case DesignType::kExplicit: {
      for (const auto& [code, names] : d.assignments) {
        const std::string path = "design.assignments." + code;
        if (!codes.count(code)) {
          throw ProtocolError(source, path, "assigns settings to " + in_quotes(code) +
                                                ", which is not in participants; every key must be a participant code");
        }
        check_setting_names(p, names, path, source);
        check_enough_settings(names.size(), path, in_quotes(code), source, p.staircase.has_value());
      }
      for (std::size_t i = 0; i < p.participants.size(); ++i) {
        if (!d.assignments.count(p.participants[i].code)) {
          throw ProtocolError(source, "design.assignments." + p.participants[i].code,
                              "is missing; an explicit design assigns settings to every participant");
        }
      }
      break;
    }
  }
}

// The study's tasks: known to its VE, listed once, each with its repetitions.
void validate_tasks(const Protocol& p, const std::string& source) {
  if (p.tasks.empty()) {
    throw ProtocolError(source, "tasks",
                        p.ve == Ve::kSimulated ? "is empty, but must list at least one of \"dissection\", \"clip\""
                                               : "is empty, but must list at least one task");
  }
  for (std::size_t i = 0; i < p.tasks.size(); ++i) {
    if (auto problem = task_name_problem(task_name(p.tasks[i]), p.ve)) {
      throw ProtocolError(source, index_path("tasks", i), "is " + in_quotes(task_name(p.tasks[i])) + ", which " + *problem);
    }
    for (std::size_t j = 0; j < i; ++j) {
      if (p.tasks[i] == p.tasks[j]) {
        throw ProtocolError(source, index_path("tasks", i),
                            "is " + in_quotes(task_name(p.tasks[i])) + ", which is already listed");
      }
    }
    const int reps = p.repetitions_of(p.tasks[i]);
    if (!p.transfer && (reps < 1 || reps > kMaxRepetitions)) {
      throw ProtocolError(source, "repetitions." + std::string(task_name(p.tasks[i])),
                          "is " + std::to_string(reps) + ", but must be >= 1 and <= " +
                              std::to_string(kMaxRepetitions) + " (repetitions of every setting)");
    }
  }
}

// The settings: named, names unique (designs refer to settings by name).
void validate_setting_names(const Protocol& p, const std::string& source) {
  for (std::size_t i = 0; i < p.settings.size(); ++i) {
    const std::string& name = p.settings[i].settings.name;
    if (name.empty()) {
      throw ProtocolError(source, index_path("settings", i) + ".name",
                          "is missing or empty, but every setting needs a name: designs refer to settings by it");
    }
    if (has_control_character(name)) {
      throw ProtocolError(source, index_path("settings", i) + ".name",
                          "is " + in_quotes(escaped(name)) +
                              ", which holds a control character (a table would cut the name there or break "
                              "its line); a setting's name must be printable text");
    }
    if (setting_name_key(name).empty()) {
      throw ProtocolError(source, index_path("settings", i) + ".name",
                          "is " + in_quotes(escaped(name)) +
                              ", which has no letter or digit; a reader tells settings apart by their names");
    }
    for (std::size_t j = 0; j < i; ++j) {
      const std::string& other = p.settings[j].settings.name;
      if (other == name) {
        throw ProtocolError(source, index_path("settings", i) + ".name",
                            "is " + in_quotes(name) + ", the same as settings[" + std::to_string(j) +
                                "]; setting names must be unique");
      }
      // "High Fidelity", "high-fidelity " and "High\u00a0Fidelity" are one
      // name to a reader, who cannot tell which table row is which.
      if (setting_name_key(other) == setting_name_key(name)) {
        throw ProtocolError(source, index_path("settings", i) + ".name",
                            "is " + in_quotes(escaped(name)) + ", the same as settings[" + std::to_string(j) +
                                "] (" + in_quotes(escaped(other)) + ") but for case, spaces, punctuation or "
                                "accents; setting names must be unique ignoring them (a reader could not tell "
                                "them apart in a table)");
      }
      // analyze finds the control by this form: two would leave it unknown.
      if (control_name_key(other) == "high_fidelity" && control_name_key(name) == "high_fidelity") {
        throw ProtocolError(source, index_path("settings", i) + ".name",
                            "is " + in_quotes(escaped(name)) + ", and settings[" + std::to_string(j) + "] is " +
                                in_quotes(escaped(other)) + ": both read as 'High Fidelity', the name analyze "
                                "finds the control by; rename one");
      }
    }
  }
}

// One participant: a new valid code, some of the study's tasks, training.
void validate_participant(const Protocol& p, std::size_t i, std::set<std::string>& codes,
                          const std::string& source) {
  const ParticipantSpec& ps = p.participants[i];
  const std::string path = index_path("participants", i);
  if (auto problem = participant_code_problem(ps.code)) {
    throw ProtocolError(source, path + ".code", "is " + in_quotes(ps.code) + ", which " + *problem);
  }
  if (!codes.insert(ps.code).second) {
    throw ProtocolError(source, path + ".code",
                        "is " + in_quotes(ps.code) + ", which is already used; codes must be unique");
  }
  // An operator who types "s1" for "S1" would run another person's
  // schedule; a merge would count one person at two sites as two.
  for (std::size_t j = 0; j < i; ++j) {
    const std::string& other = p.participants[j].code;
    if (other.size() == ps.code.size() &&
        std::equal(other.begin(), other.end(), ps.code.begin(), [](char a, char b) {
          return std::tolower(static_cast<unsigned char>(a)) == std::tolower(static_cast<unsigned char>(b));
        }))
      throw ProtocolError(source, path + ".code",
                          "is " + in_quotes(ps.code) + ", the same as participants[" + std::to_string(j) + "] (" +
                              in_quotes(other) + ") but for case; codes must be unique ignoring case (an operator "
                              "typing one would run the other's schedule)");
  }
  if (ps.tasks.empty()) {
    throw ProtocolError(source, path + ".tasks", "is empty, but must list at least one of the study's tasks");
  }
  for (std::size_t t = 0; t < ps.tasks.size(); ++t) {
    bool in_study = false;
    for (const Task& st : p.tasks) in_study = in_study || st == ps.tasks[t];
    if (!in_study) {
      throw ProtocolError(source, index_path(path + ".tasks", t),
                          "is " + in_quotes(task_name(ps.tasks[t])) + ", which is not one of the study's tasks");
    }
    for (std::size_t u = 0; u < t; ++u) {
      if (ps.tasks[u] == ps.tasks[t]) {
        throw ProtocolError(source, index_path(path + ".tasks", t),
                            "is " + in_quotes(task_name(ps.tasks[t])) + ", which is already listed");
      }
    }
  }
  if (ps.training_trials < 0 || ps.training_trials > kMaxTrainingTrials) {
    throw ProtocolError(source, path + ".training_trials",
                        "is " + std::to_string(ps.training_trials) + ", but must be >= 0 and <= " +
                            std::to_string(kMaxTrainingTrials));
  }
}

}  // namespace

// Force limits that leave no force feedback in any setting: a study of
// degradations needs a reference that has it. (Checked when a study is
// created; a stored protocol is only read back.)
void validate_safety(const Protocol& p, const std::string& source) {
  if (p.safety.peak_force_fraction == 0.0) {
    throw ProtocolError(source, "safety.peak_force_fraction",
                        "is 0, which clamps every force of every trial to zero: no setting, not even the control, "
                        "would give force feedback; give a fraction of the device's peak output > 0 and <= 1, or "
                        "leave it out for the device's own limits");
  }
  if (p.safety.insertion_force_N == 0.0 && p.safety.pitch_yaw_torque_Nm == 0.0) {
    throw ProtocolError(source, "safety.max_insertion_force_N",
                        "is 0, and safety.max_pitch_yaw_torque_Nm is 0 too: no setting, not even the control, "
                        "would push back on the instrument; give limits > 0, or leave them out for the "
                        "device's own");
  }
}

void validate_protocol(const Protocol& p, const std::string& source) {
  if (p.study.empty()) throw ProtocolError(source, "study", "is empty, but must name the study");
  if (has_control_character(p.study) || setting_name_key(p.study).empty()) {
    throw ProtocolError(source, "study",
                        "is " + in_quotes(escaped(p.study)) +
                            ", but must name the study in printable text with at least one letter or digit");
  }
  validate_safety(p, source);
  validate_tasks(p, source);
  validate_setting_names(p, source);
  if (p.settings.size() < (p.staircase ? 1u : 2u)) {
    throw ProtocolError(source, "settings",
                        "has " + std::to_string(p.settings.size()) + " setting(s), but must have at least 2");
  }

  // Only `session run` adds a staircase's trials; the study API, which an
  // external VE's application drives, has none.
  if (p.staircase && p.ve == Ve::kExternal) {
    throw ProtocolError(source, "staircase",
                        "is given with \"ve\": \"external\", but an external VE's application runs the study "
                        "through the study API (hapticlab/study.h), which never runs a staircase (only `session "
                        "run` adds its trials, with the simulated VE): remove \"staircase\" or \"ve\"");
  }

  // participants: codes, tasks, training
  if (p.participants.empty()) {
    throw ProtocolError(source, "participants", "is empty, but must list at least one participant code");
  }
  std::set<std::string> codes;
  for (std::size_t i = 0; i < p.participants.size(); ++i) validate_participant(p, i, codes, source);

  // A between-group design has its own rules and no within-participant design.
  if (p.transfer) {
    validate_transfer_design(p, source);
    return;
  }
  validate_design(p, codes, source);
}

}  // namespace hapticlab::protocols
