#pragma once
// A study protocol: which tasks, which settings, who takes part, how settings
// are assigned to participants (the design), how often each is repeated, and
// the seed that fixes every random choice. Plain data; protocol_json.h reads
// and validates it, design.h assigns settings, schedule.h orders the trials.
//
// Thesis (Ch. 3.3.6): 2 tasks, 8 settings, 3 dissection and 9 clip
// repetitions of every setting; planned 8 surgeons in an incomplete design
// (Table 3.2), run with 3 (Table 3.3).

#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/loop/force_guard.h"
#include "core/loop/rate_monitor.h"
#include "core/settings/settings_json.h"
#include "protocols/staircase.h"
#include "protocols/transfer_design.h"

namespace hapticlab::protocols {

// Where the tasks happen. kSimulated: HapticLab's own VE, which knows the
// thesis' two tasks (Ch. 3.3.2) and runs them in `session run`. kExternal:
// the lab's own VE, driven by its application through the study API
// (hapticlab/study.h); the tasks are the lab's, named freely. Protocol
// files say "ve": "simulated" (the default) or "external".
enum class Ve { kSimulated = 0, kExternal = 1 };
std::string_view ve_name(Ve ve);

// A task of the study, by its name in the protocol file: with the
// simulated VE "dissection" or "clip", with an external VE the lab's own
// (task_name_problem says which names are accepted).
class Task {
 public:
  Task() = default;
  explicit Task(std::string name) : name_(std::move(name)) {}
  const std::string& name() const noexcept { return name_; }
  friend bool operator==(const Task&, const Task&) = default;
  friend auto operator<=>(const Task&, const Task&) = default;

  static const Task kDissection;
  static const Task kClip;

 private:
  std::string name_;
};
inline const Task Task::kDissection{"dissection"};
inline const Task Task::kClip{"clip"};
// The simulated VE's tasks, in the order its counterbalancing uses.
inline constexpr std::size_t kSimulatedTaskCount = 2;

// The name used in protocol files and the database.
std::string_view task_name(const Task& task);
// A simulated VE's task called `name`, or nullopt.
std::optional<Task> task_from_name(std::string_view name);

// Task names of an external VE: 1..kMaxTaskNameLength bytes of printable
// text (UTF-8 allowed, no control characters), no leading or trailing space.
inline constexpr std::size_t kMaxTaskNameLength = 64;
// Why `name` is not an acceptable task name for `ve`, or nullopt if it is.
std::optional<std::string> task_name_problem(std::string_view name, Ve ve);

// Repetitions allowed per setting and task (each repetition is one block).
inline constexpr int kMaxRepetitions = 100;
// Practice trials allowed per participant and task.
inline constexpr int kMaxTrainingTrials = 1000;
// Participant codes: 1..kMaxCodeLength of [A-Za-z0-9_-].
inline constexpr std::size_t kMaxCodeLength = 32;

// One setting of the study, with its full parameters (so a results database
// can store exactly what ran, not a file name whose content may change).
struct ProtocolSetting {
  NamedSettings settings;  // settings.name is how designs refer to it; unique per protocol
  std::string source;      // the path as written in the protocol file, or "inline"
};

enum class DesignType {
  kComplete,    // every participant does every setting
  kIncomplete,  // `required` for all, plus `k` of the others, balanced (design.h)
  kExplicit,    // `assignments` given per participant (e.g. thesis Table 3.3)
};

struct Design {
  DesignType type = DesignType::kComplete;
  // kIncomplete: setting names every participant does (thesis: High
  // Fidelity, No Force Feedback, All Degradations). The other settings of the
  // protocol, in protocol order, are the optional ones.
  std::vector<std::string> required;
  // kIncomplete: optional settings per participant, 0 <= k <= optional count.
  int k = 0;
  // kExplicit: participant code -> setting names; exactly one entry per participant.
  std::map<std::string, std::vector<std::string>> assignments;
};

struct ParticipantSpec {
  // Pseudonymous code, 1..32 of [A-Za-z0-9_-]. Never a name: protocol files
  // and everything derived from them (schedules, databases) hold codes only.
  std::string code;
  // Tasks this participant does, a non-empty subset of Protocol::tasks in
  // protocol order (thesis: Surgeon 3 did only the dissection).
  std::vector<Task> tasks;
  // Practice trials per task before its scheduled trials, 0..1000. Not part
  // of the schedule and not analysed; simulated participants use them to
  // settle (the thesis' surgeons trained until they stopped improving).
  int training_trials = 0;
  // Attributes by name (e.g. "experience": "novice"), from the protocol
  // file; a between-group design may stratify by one (transfer_design.h).
  // Values are 1..64 bytes of text.
  std::map<std::string, std::string> attributes = {};  // "= {}": braced lists that stop at training_trials stay warning-free
};

// The "staircase" block: the settings its strengths are made from, and the
// rule (protocols/staircase.h). Its trials are not scheduled in advance:
// `session run` adds each one after the participant's schedule is done.
struct ProtocolStaircase {
  ProtocolSetting base;  // the field is set to each strength, its block switched on
  StaircaseSpec spec;
};

// The name the study database gives the staircase's base settings, so a
// session can find them without the protocol's files.
std::string staircase_base_row_name(std::string_view base_name);
inline constexpr std::string_view kStaircaseBasePrefix = "staircase: ";

// The range of "rate_tolerance_fraction" (docs/protocols.md).
inline constexpr double kMinRateToleranceFraction = 0.001;
inline constexpr double kMaxRateToleranceFraction = 0.5;

struct Protocol {
  std::string study;                      // study name, non-empty
  std::string description;                // free text, may be empty
  Ve ve = Ve::kSimulated;                 // where the tasks run
  std::vector<Task> tasks;                // non-empty, no duplicates, in file order
  std::vector<ProtocolSetting> settings;  // >= 2, names unique ignoring case and surrounding spaces
  // Repetitions of every setting per task, 1..100, for every task in
  // `tasks` (thesis: 3 dissection, 9 clip).
  std::map<Task, int> repetitions;
  std::vector<ParticipantSpec> participants;  // >= 1, unique codes
  Design design;
  std::uint64_t seed = 0;  // fixes the design search, task orders and schedules
  // The optional "safety" object: force limits below the device's
  // (protocols/safety_json.h, docs/safety.md). Default: the device's own.
  OperatorForceLimits safety;
  // How far the haptic loop's achieved update rate may stray from the
  // session's (fraction, over each 1 s window; core/loop/rate_monitor.h)
  // before a trial ends as rate_violation and is re-queued.
  double rate_tolerance_fraction = RateCheck::kDefaultToleranceFraction;
  // The optional "null_settings": settings that are the control's
  // parameters under another name, so that any difference found for them is
  // a false positive (`plan power` counts them and refuses one that is not
  // such a copy). Names of `settings`; nothing else reads them.
  std::vector<std::string> null_settings;
  // The optional "staircase" (a protocol has it or "dose", not both).
  std::optional<ProtocolStaircase> staircase;
  // The optional between-group training design ("groups", "stratify_by",
  // "phases"): when present, `design` and `repetitions` are unused (every
  // trial comes from a phase) and schedules follow the phases (schedule.h).
  std::optional<TransferDesign> transfer;

  // 0 for a task without repetitions.
  int repetitions_of(const Task& task) const {
    const auto it = repetitions.find(task);
    return it == repetitions.end() ? 0 : it->second;
  }
  // Index into `settings` of the setting called `name`, or nullopt.
  std::optional<std::size_t> find_setting(std::string_view name) const;
};

// The form in which two setting names are the same name to a reader: ASCII
// letters in lower case; a sign before a digit and a decimal point between
// digits kept ("+20" and "-20", "0.5" and "05" differ); runs of anything
// else ASCII (spaces, other punctuation) and of Unicode spaces (no-break,
// thin, ideographic, zero-width) one '_',
// none at the ends; accents dropped (a Latin-1 letter as its base letter,
// combining marks U+0300..U+036F left out, so "Café" typed composed and
// decomposed is one name); any other character kept. A protocol's setting
// names are unique in this form ("High Fidelity", "high-fidelity " and
// "High\u00a0Fidelity" are refused together).
std::string setting_name_key(std::string_view name);

// The form in which `analyze` finds the control, "high_fidelity": ASCII
// letters and digits in lower case, every run of anything else one '_'.
std::string control_name_key(std::string_view name);

// Why `code` is not an acceptable participant code, or nullopt if it is.
// A code with a space is refused as looking like a person's name.
std::optional<std::string> participant_code_problem(std::string_view code);

// Checks every rule of docs/protocols.md on a protocol built in code or
// parsed from a file; throws ProtocolError naming the field by its path in
// the protocol file (e.g. "design.required[1]", "participants[2].code"),
// the value and the rule. `source` prefixes the message (a file path).
// Among the rules: every participant ends up with >= 2 settings, because a
// within-subject comparison needs two, and with one setting every trial
// would repeat it (block randomization could not keep runs <= 2).
void validate_protocol(const Protocol& protocol, const std::string& source);

}  // namespace hapticlab::protocols
