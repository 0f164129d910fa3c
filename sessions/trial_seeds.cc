#include "sessions/trial_seeds.h"

#include <string>

#include "core/common/random.h"
#include "protocols/rng.h"

namespace hapticlab::sessions {

std::uint64_t participant_seed(std::uint64_t study_seed, std::string_view code) noexcept {
  Random r = Random::derive(study_seed, protocols::fnv1a64(code));
  return r.next_u64();
}

std::uint64_t trial_seed(std::uint64_t participant_seed, std::int64_t trial_id) noexcept {
  Random r = Random::derive(participant_seed, static_cast<std::uint64_t>(trial_id));
  return r.next_u64();
}

std::uint64_t training_seed(std::uint64_t participant_seed, std::string_view task, int k) noexcept {
  return Random::derive(participant_seed, protocols::fnv1a64("training:" + std::string(task))).next_u64() +
         static_cast<std::uint64_t>(k);
}

std::uint64_t staircase_trial_seed(std::uint64_t participant_seed, int position) noexcept {
  return Random::derive(participant_seed, protocols::fnv1a64("staircase")).next_u64() +
         static_cast<std::uint64_t>(position);
}

std::uint64_t scheduled_trial_seed(std::uint64_t participant_seed, const db::TrialRow& trial,
                                   const std::vector<db::TrialRow>& participant_trials) noexcept {
  if (trial.block == 0) return staircase_trial_seed(participant_seed, trial.position);
  // A re-queued copy keeps its slot (task, setting, repetition, block,
  // position: study_session.cc's slot_of) and gets a new, larger id.
  std::int64_t first = trial.id;
  for (const db::TrialRow& t : participant_trials)
    if (t.id < first && t.task == trial.task && t.setting_id == trial.setting_id &&
        t.repetition == trial.repetition && t.block == trial.block && t.position == trial.position)
      first = t.id;
  return trial_seed(participant_seed, first);
}

}  // namespace hapticlab::sessions
