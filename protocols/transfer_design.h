#pragma once
// A between-group training design (issue 38 §1): participants randomized to
// groups, each group trained on its own setting, everyone tested on the
// test settings in phases: pre-test, N training sessions, post-test and an
// optional retention test after a delay. Plain data; protocol_json.cc reads
// it from "groups", "stratify_by" and "phases", validate_transfer_design
// (transfer_rules.h) checks it, group_assignment.h randomizes participants
// and sittings.h turns the phases into sittings with due dates.
//
// A protocol with groups has no "design" and no "repetitions": every trial
// comes from a phase. Format and ranges: docs/protocols.md, "Groups and
// phases".

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace hapticlab::protocols {

enum class PhaseKind { kPreTest = 0, kTraining = 1, kPostTest = 2, kRetention = 3 };
// "pre_test", "training", "post_test", "retention": the names in protocol files.
std::string_view phase_kind_name(PhaseKind kind);
std::optional<PhaseKind> phase_kind_from_name(std::string_view name);

// Ranges of the phase fields (docs/protocols.md).
inline constexpr int kMaxTrainingSessions = 100;
inline constexpr int kMaxPhaseTrials = 100;         // per task and sitting
inline constexpr double kMaxMinGap_h = 24.0 * 366;  // a year
inline constexpr std::size_t kMaxGroupNameLength = 64;

struct Phase {
  PhaseKind kind = PhaseKind::kPreTest;
  // Tests: the name of the setting every group is tested on (typically
  // "High Fidelity"). Training: empty; each group trains on its own.
  std::string setting;
  // Sittings of this phase: 1 for a test, 1..kMaxTrainingSessions for training.
  int sessions = 1;
  // Trials per sitting, by task name: 1..kMaxPhaseTrials for every task of
  // the protocol.
  std::map<std::string, int> trials;
  // Least time from the end of the previous sitting to the start of each
  // sitting of this phase, 0..kMaxMinGap_h hours (training: between its own
  // sittings too). The retention test's is its delay, which must exceed the
  // training span (transfer_rules.h).
  double min_gap_h = 0.0;
};

struct Group {
  std::string name;  // 1..64 bytes, unique per protocol
  // The setting this group trains on; nullopt for a control group that
  // trains on no simulator and only does the tests.
  std::optional<std::string> training_setting;
  // Declared number of participants, >= 1; when one group declares it,
  // every group does, and they sum to the participant count.
  std::optional<int> size;
};

struct TransferDesign {
  std::vector<Group> groups;  // >= 1
  // The participant attribute randomization is stratified by (e.g.
  // "experience"); empty: no stratification. Every participant must have it.
  std::string stratify_by;
  // In the order pre_test, training, post_test, retention; training and
  // post_test required, pre_test and retention optional, each at most once.
  std::vector<Phase> phases;

  const Phase* find_phase(PhaseKind kind) const {
    for (const Phase& ph : phases)
      if (ph.kind == kind) return &ph;
    return nullptr;
  }
};

}  // namespace hapticlab::protocols
