#include "planning/transfer_study.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "core/common/csv_format.h"
#include "core/sim/trial_runner.h"
#include "sessions/session_runner.h"

namespace hapticlab::planning {
namespace {

[[noreturn]] void refuse(const std::string& field, const std::string& value, const std::string& range) {
  throw std::invalid_argument(field + " is " + value + ", but must be " + range);
}

double mean_of_complete(const std::vector<TransferTrial>& trials, TransferPhase phase) {
  double sum = 0.0;
  int n = 0;
  for (const TransferTrial& t : trials) {
    if (t.phase != phase || !t.complete) continue;
    sum += t.time_s;
    ++n;
  }
  return n > 0 ? sum / n : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

const char* transfer_phase_name(TransferPhase phase) noexcept {
  switch (phase) {
    case TransferPhase::kFamiliarization: return "familiarization";
    case TransferPhase::kPreTest: return "pre";
    case TransferPhase::kTraining: return "training";
    case TransferPhase::kPostTest: return "post";
    case TransferPhase::kRetention: return "retention";
  }
  return "?";
}

void TransferDesign::validate() const {
  (void)parse_task_kind(task);  // throws, naming the task
  if (familiarization_trials < 0 || familiarization_trials > 1000)
    refuse("familiarization_trials", std::to_string(familiarization_trials), "within 0..1000");
  if (pre_trials < 0 || pre_trials > 100) refuse("pre_trials", std::to_string(pre_trials), "within 0..100");
  if (post_trials < 1 || post_trials > 100) refuse("post_trials", std::to_string(post_trials), "within 1..100");
  if (retention_trials < 0 || retention_trials > 100)
    refuse("retention_trials", std::to_string(retention_trials), "within 0..100");
  if (groups.size() < 2) refuse("groups", std::to_string(groups.size()) + " groups", "at least 2");
  for (std::size_t g = 0; g < groups.size(); ++g) {
    for (std::size_t b = 0; b < groups[g].training.size(); ++b) {
      if (groups[g].training[b].trials < 1)
        refuse("groups[" + std::to_string(g) + "] (" + groups[g].name + ").training[" + std::to_string(b) + "].trials",
               std::to_string(groups[g].training[b].trials), ">= 1");
    }
  }
}

TransferStudy simulate_transfer_study(const TransferDesign& design, int per_group, std::uint64_t seed,
                                      const TransferOptions& options) {
  design.validate();
  options.learning.validate();
  options.population.validate();
  if (per_group < 1 || per_group > 999) refuse("participants per group", std::to_string(per_group), "within 1..999");
  TransferStudy out;
  for (std::size_t g = 0; g < design.groups.size(); ++g) {
    for (int i = 0; i < per_group; ++i) {
      TransferParticipant person;
      char number[8];
      std::snprintf(number, sizeof number, "%03d", i + 1);
      person.code = "G" + std::to_string(g + 1) + "P" + number;
      person.group = static_cast<int>(g);
      const std::uint64_t who = sessions::participant_seed(seed, person.code);
      PracticeSoFar practice;
      auto run = [&](TransferPhase phase, const EngineSettings& settings) {
        SimTrialConfig c;
        c.task = parse_task_kind(design.task);
        c.settings = settings;
        c.participant_seed = who;
        c.population = options.population;
        c.trial_seed = sessions::trial_seed(who, static_cast<std::int64_t>(person.trials.size()) + 1);
        c.practice_trials = practice.trials;
        c.force_informed_trials = practice.force_informed_trials;
        c.learning = options.learning;
        c.rate_Hz = options.rate_Hz;
        c.max_duration_s = options.max_trial_s;
        c.safety = options.protections;
        c.publish_samples = false;
        const SimTrialResult r = run_sim_trial(c);
        TransferTrial t;
        t.phase = phase;
        t.number = static_cast<int>(person.trials.size()) + 1;
        t.time_s = r.duration_s;
        t.complete = r.task_complete;
        t.force_information = std::isfinite(r.force_information) ? r.force_information : 0.0;
        person.trials.push_back(t);
        // Every trial is practice, a timed-out one too; clamped so rounding
        // never lets the weighted count pass the count.
        ++practice.trials;
        practice.force_informed_trials =
            std::min(practice.force_informed_trials + t.force_information, static_cast<double>(practice.trials));
        ++out.trials_run;
        if (!r.task_complete) ++out.trials_timed_out;
        out.updates += r.samples;
      };
      for (int k = 0; k < design.familiarization_trials; ++k)
        run(TransferPhase::kFamiliarization, design.test_settings);
      for (int k = 0; k < design.pre_trials; ++k) run(TransferPhase::kPreTest, design.test_settings);
      for (const TrainingBlock& block : design.groups[g].training) {
        for (int k = 0; k < block.trials; ++k) run(TransferPhase::kTraining, block.settings);
      }
      for (int k = 0; k < design.post_trials; ++k) run(TransferPhase::kPostTest, design.test_settings);
      for (int k = 0; k < design.retention_trials; ++k) run(TransferPhase::kRetention, design.test_settings);
      person.pre_s = mean_of_complete(person.trials, TransferPhase::kPreTest);
      person.post_s = mean_of_complete(person.trials, TransferPhase::kPostTest);
      person.retention_s = mean_of_complete(person.trials, TransferPhase::kRetention);
      out.participants.push_back(std::move(person));
    }
  }
  return out;
}

}  // namespace hapticlab::planning
