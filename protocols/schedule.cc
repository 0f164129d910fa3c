#include "protocols/schedule.h"

#include <algorithm>
#include <map>
#include <numeric>
#include <stdexcept>

#include "protocols/design.h"
#include "protocols/group_assignment.h"
#include "protocols/sittings.h"

namespace hapticlab::protocols {
namespace {

// "A".."Z", then "AA", "AB", ... (spreadsheet columns).
std::string letters(std::size_t i) {
  std::string s;
  ++i;
  while (i > 0) {
    --i;
    s.insert(s.begin(), static_cast<char>('A' + i % 26));
    i /= 26;
  }
  return s;
}

// Participants doing every task of the study are the ones whose order is
// counterbalanced (the others do theirs in protocol order).
bool does_all_tasks(const Protocol& protocol, const ParticipantSpec& ps) {
  return protocol.tasks.size() >= 2 && ps.tasks.size() == protocol.tasks.size();
}

// Blinding labels: letters handed out in a random order.
void add_condition_labels(const Protocol& protocol, ParticipantPlan& pp) {
  Rng label_rng = Rng::for_stream(protocol.seed, "labels/" + pp.code);
  std::vector<std::size_t> letter_of(pp.setting_indices.size());
  std::iota(letter_of.begin(), letter_of.end(), 0);
  shuffle(letter_of, label_rng);
  for (std::size_t l : letter_of) pp.condition_labels.push_back(letters(l));
}

StudyPlan make_group_study_plan(const Protocol& protocol) {
  const std::string source = "protocol \"" + protocol.study + "\"";
  const auto groups = assign_groups(protocol, source);
  const auto task_orders = counterbalanced_task_orders(protocol);
  StudyPlan plan;
  plan.study = protocol.study;
  plan.seed = protocol.seed;
  for (std::size_t p = 0; p < protocol.participants.size(); ++p) {
    const ParticipantSpec& spec = protocol.participants[p];
    ParticipantPlan pp;
    pp.code = spec.code;
    pp.task_order = task_orders[p];
    pp.training_trials = spec.training_trials;
    pp.group = groups[p];
    pp.group_name = protocol.transfer->groups[groups[p]].name;
    const std::vector<Sitting> sittings = group_sittings(protocol, groups[p]);
    for (const Sitting& s : sittings) {
      const std::size_t index = protocol.find_setting(s.setting).value();
      if (std::find(pp.setting_indices.begin(), pp.setting_indices.end(), index) == pp.setting_indices.end())
        pp.setting_indices.push_back(index);
    }
    std::sort(pp.setting_indices.begin(), pp.setting_indices.end());
    for (std::size_t i : pp.setting_indices) pp.settings.push_back(protocol.settings[i].settings);
    add_condition_labels(protocol, pp);
    std::map<std::pair<Task, std::size_t>, int> seen;  // (task, setting) -> trials so far
    int position = 0;
    for (std::size_t k = 0; k < sittings.size(); ++k) {
      const std::size_t index = protocol.find_setting(sittings[k].setting).value();
      for (const Task& task : pp.task_order) {
        for (int t = 0; t < sittings[k].trials.at(std::string(task_name(task))); ++t) {
          PlannedTrial trial;
          trial.participant = spec.code;
          trial.task = task;
          trial.setting_index = index;
          trial.setting = sittings[k].setting;
          trial.repetition = ++seen[{task, index}];
          trial.block = static_cast<int>(k) + 1;
          trial.sitting = static_cast<int>(k) + 1;
          trial.position = ++position;
          pp.trials.push_back(std::move(trial));
        }
      }
    }
    plan.participants.push_back(std::move(pp));
  }
  return plan;
}

}  // namespace

std::vector<std::size_t> block_randomized_order(std::size_t setting_count, int blocks, Rng& rng) {
  if (setting_count == 0) throw std::invalid_argument("block_randomized_order(): setting_count must be >= 1");
  if (blocks < 0) throw std::invalid_argument("block_randomized_order(): blocks must be >= 0");
  if (setting_count == 1 && blocks > kMaxRun) {
    throw std::invalid_argument("block_randomized_order(): with 1 setting, blocks must be <= 2; every trial would "
                                "be at the same setting, more than 2 in a row");
  }
  std::vector<std::size_t> order;
  order.reserve(setting_count * static_cast<std::size_t>(blocks));
  std::vector<std::size_t> block(setting_count);
  for (int b = 0; b < blocks; ++b) {
    std::iota(block.begin(), block.end(), 0);
    shuffle(block, rng);
    order.insert(order.end(), block.begin(), block.end());
  }
  return order;
}

std::vector<std::vector<Task>> counterbalanced_task_orders(const Protocol& protocol) {
  Rng rng = Rng::for_stream(protocol.seed, "task-order");
  // The pair's "first" order: the simulated VE's tasks in the thesis' order
  // (dissection, clip) whatever the file's order; a lab's own in file order.
  const std::vector<Task> canonical = protocol.ve == Ve::kSimulated
                                          ? std::vector<Task>{Task::kDissection, Task::kClip}
                                          : protocol.tasks;
  std::vector<std::vector<Task>> orders;
  bool pair_open = false;   // the previous all-task participant started a pair
  bool previous_first_canonical = false;
  std::size_t rotation = 0;  // more than two tasks: all-task participants so far
  for (const ParticipantSpec& ps : protocol.participants) {
    std::vector<Task> order = ps.tasks;
    if (does_all_tasks(protocol, ps) && canonical.size() == 2) {
      // First of a pair: coin; second: the other order.
      const bool first_canonical = pair_open ? !previous_first_canonical : rng.coin();
      order = first_canonical ? canonical : std::vector<Task>{canonical[1], canonical[0]};
      previous_first_canonical = first_canonical;
      pair_open = !pair_open;
    } else if (does_all_tasks(protocol, ps)) {
      // More tasks (an external VE): a rotation per participant, so every
      // task is first equally often over each run of participants.
      order = canonical;
      std::rotate(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(rotation % order.size()), order.end());
      ++rotation;
    }
    orders.push_back(std::move(order));
  }
  return orders;
}

int longest_run(const std::vector<PlannedTrial>& trials) {
  int longest = 0;
  int run = 0;
  for (std::size_t i = 0; i < trials.size(); ++i) {
    run = (i > 0 && trials[i].setting_index == trials[i - 1].setting_index) ? run + 1 : 1;
    longest = std::max(longest, run);
  }
  return longest;
}

StudyPlan make_study_plan(const Protocol& protocol) {
  validate_protocol(protocol, "protocol \"" + protocol.study + "\"");
  if (protocol.transfer) return make_group_study_plan(protocol);
  const auto assignments = assign_settings(protocol);
  const auto task_orders = counterbalanced_task_orders(protocol);

  StudyPlan plan;
  plan.study = protocol.study;
  plan.seed = protocol.seed;
  for (std::size_t p = 0; p < protocol.participants.size(); ++p) {
    const ParticipantSpec& spec = protocol.participants[p];
    ParticipantPlan pp;
    pp.code = spec.code;
    pp.task_order = task_orders[p];
    pp.setting_indices = assignments[p];
    pp.training_trials = spec.training_trials;
    for (std::size_t i : pp.setting_indices) pp.settings.push_back(protocol.settings[i].settings);

    add_condition_labels(protocol, pp);

    // Blocks, task by task, in the counterbalanced order.
    Rng rng = Rng::for_stream(protocol.seed, "schedule/" + spec.code);
    int position = 0;
    for (const Task& task : pp.task_order) {
      const int blocks = protocol.repetitions_of(task);
      // A staircase protocol's baseline alone has nothing to randomize.
      const auto order = pp.setting_indices.size() == 1
                             ? std::vector<std::size_t>(static_cast<std::size_t>(blocks), 0)
                             : block_randomized_order(pp.setting_indices.size(), blocks, rng);
      std::vector<int> seen(pp.setting_indices.size(), 0);
      for (std::size_t t = 0; t < order.size(); ++t) {
        const std::size_t local = order[t];
        PlannedTrial trial;
        trial.participant = spec.code;
        trial.task = task;
        trial.setting_index = pp.setting_indices[local];
        trial.setting = protocol.settings[trial.setting_index].settings.name;
        trial.repetition = ++seen[local];
        trial.block = static_cast<int>(t / pp.setting_indices.size()) + 1;
        trial.position = ++position;
        pp.trials.push_back(std::move(trial));
      }
    }

    // Always-on check of the thesis' rule; blocks guarantee it, this makes
    // sure no later change breaks it silently. (A staircase protocol may
    // schedule its baseline alone, which cannot alternate.)
    if (pp.setting_indices.size() > 1 && longest_run(pp.trials) > kMaxRun) {
      throw std::logic_error("make_study_plan(): participant " + spec.code + " has more than " +
                             std::to_string(kMaxRun) + " consecutive trials at one setting");
    }
    plan.participants.push_back(std::move(pp));
  }
  return plan;
}

std::vector<PlannedTrial> all_trials(const StudyPlan& plan) {
  std::vector<PlannedTrial> out;
  for (const auto& pp : plan.participants) out.insert(out.end(), pp.trials.begin(), pp.trials.end());
  return out;
}

std::vector<BlindedTrial> participant_view(const ParticipantPlan& participant) {
  std::vector<BlindedTrial> out;
  out.reserve(participant.trials.size());
  for (const PlannedTrial& t : participant.trials) {
    const auto it =
        std::find(participant.setting_indices.begin(), participant.setting_indices.end(), t.setting_index);
    if (it == participant.setting_indices.end()) {
      throw std::invalid_argument("participant_view(): a trial's setting is not one of the participant's settings");
    }
    const auto local = static_cast<std::size_t>(it - participant.setting_indices.begin());
    out.push_back({t.position, t.task, "Condition " + participant.condition_labels.at(local)});
  }
  return out;
}

}  // namespace hapticlab::protocols
