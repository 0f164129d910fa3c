#pragma once
// Block-randomized trial schedules (thesis 4.2.2.2).
//
// The thesis' study presented settings in plain random order, and one
// surgeon ended up doing No Force Feedback three times in a row at the end
// of a session, which may have biased the learning-effect analysis. The
// thesis recommends blocks instead; this is that:
//
//   for each participant, tasks in a counterbalanced order;
//     for each task, `repetitions` blocks;
//       each block holds every one of the participant's settings once,
//       in a freshly shuffled order.
//
// So a setting can repeat only across a block boundary (last of one block,
// first of the next): never more than 2 trials in a row at one setting, and
// every setting spread evenly over the session. The schedule is checked
// against that rule before it is returned.
//
// Task order: participants who do both tasks are taken in protocol order in
// pairs; in each pair one starts with dissection and the other with clip, a
// seeded coin deciding which. Every prefix of the participant list is then
// balanced within one, which matters when a study stops early (the thesis
// ran 3 of 8 planned participants). An external VE's two tasks are paired
// the same way (the first-listed in dissection's role); with more tasks,
// participants doing all of them take successive rotations of the
// protocol's order.
//
// Random streams (rng.h), all keyed by Protocol::seed: "design" (design.h),
// "task-order", "schedule/<code>", "labels/<code>". A participant's schedule
// depends only on the seed, their code and settings, and the repetitions.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/settings/settings_json.h"
#include "protocols/protocol.h"
#include "protocols/rng.h"

namespace hapticlab::protocols {

// One planned trial, as the experimenter (not the participant) sees it.
struct PlannedTrial {
  std::string participant;        // participant code
  Task task = Task::kDissection;
  std::string setting;            // setting name
  std::size_t setting_index = 0;  // into Protocol::settings
  int repetition = 0;  // 1-based: the how-many-th trial at this setting in this task
  int block = 0;       // 1-based block within this task; equals repetition by construction
  int position = 0;    // 1-based position in this participant's whole schedule
  // A group design's (sittings.h): the 1-based sitting this trial belongs
  // to, whose number is also its block; 0 in a within-participant design.
  int sitting = 0;
};

struct ParticipantPlan {
  std::string code;
  std::vector<Task> task_order;            // the participant's tasks in the order done
  std::vector<std::size_t> setting_indices;  // into Protocol::settings, protocol order
  // Full parameters of those settings (parallel to setting_indices), so a
  // results database can store exactly what each participant felt.
  std::vector<NamedSettings> settings;
  // Opaque labels shown to the participant instead of setting names
  // (parallel to setting_indices): "A", "B", ... assigned in a random
  // order per participant, so neither the label nor its letter order says
  // which setting it is.
  std::vector<std::string> condition_labels;
  int training_trials = 0;            // per task, before its first trial (protocol.h)
  std::vector<PlannedTrial> trials;   // in schedule order; trials[i].position == i + 1
  // A group design's: the participant's group (index into
  // TransferDesign::groups) and its name; 0 and empty otherwise. Never
  // shown to the participant (blinding: the group says the setting).
  std::size_t group = 0;
  std::string group_name;
};

struct StudyPlan {
  std::string study;
  std::uint64_t seed = 0;
  std::vector<ParticipantPlan> participants;  // in Protocol::participants order
};

// The whole study: design, task orders and schedules. A protocol with
// groups (transfer_design.h) gets its schedules from its phases instead:
// each participant's sittings in order (sittings.h), each sitting its tasks
// in the participant's counterbalanced order, each task its trials at the
// sitting's setting; the at-most-2-in-a-row rule does not apply (a test is
// many trials at one setting by design). The protocol is
// validated first (ProtocolError). Same protocol and seed -> same plan on
// any platform.
StudyPlan make_study_plan(const Protocol& protocol);

// Every trial of the study, participant by participant.
std::vector<PlannedTrial> all_trials(const StudyPlan& plan);

// The counterbalanced task order of each participant (Protocol::participants
// order); see the header comment.
std::vector<std::vector<Task>> counterbalanced_task_orders(const Protocol& protocol);

// `blocks` blocks of a shuffled 0..setting_count-1 each, concatenated.
// Throws std::invalid_argument if setting_count == 0, or if
// setting_count == 1 and blocks > 2 (every trial would be the one setting,
// breaking the at-most-2-in-a-row rule).
std::vector<std::size_t> block_randomized_order(std::size_t setting_count, int blocks, Rng& rng);

// Longest run of consecutive trials at one setting (across task boundaries
// too: it is the same hand on the same device). 0 for an empty schedule.
int longest_run(const std::vector<PlannedTrial>& trials);

// The most consecutive trials at one setting a schedule may have.
inline constexpr int kMaxRun = 2;

// What the participant may see of one trial: never the setting.
struct BlindedTrial {
  int position = 0;
  Task task = Task::kDissection;
  std::string condition;  // e.g. "Condition C"
};

std::vector<BlindedTrial> participant_view(const ParticipantPlan& participant);

}  // namespace hapticlab::protocols
