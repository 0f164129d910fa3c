#pragma once
// A between-group training study on the simulated rig (issue 38 §4): each
// group trains on its own device setting, every group is tested on the
// same setting before training, after it and again later, and the
// simulated participants learn from the force information their hands
// received (core/sim/practice.h). Nothing is stored: thousands of such
// studies say what a transfer design can detect.
//
// The simulation sees settings only as engine parameters, never by name.
// A group with no training blocks is a control that only takes the tests
// (no simulator training).
//
// What the model does not have, so cannot predict: forgetting (a retention
// test differs from the post-test only by its trials' variation: the
// practice count does not decay with the delay), fatigue within a session,
// and an order effect of training blocks (effective practice is a sum, so
// "haptic first, then none" equals "none, then haptic" at the end;
// docs/simulation.md "Simulated learners" compares this with Ström et al.
// 2006, who found the order mattered).
#include <cstdint>
#include <string>
#include <vector>

#include "core/loop/haptic_loop.h"
#include "core/settings/settings.h"
#include "core/sim/population.h"
#include "core/sim/practice.h"

namespace hapticlab::planning {

struct TrainingBlock {
  EngineSettings settings;
  int trials = 0;  // >= 1
};

struct TransferGroup {
  std::string name;                    // for output only; the simulation never reads it
  std::vector<TrainingBlock> training;  // in order; empty: a control group that only takes the tests
};

struct TransferDesign {
  std::string task = "dissection";  // "dissection" or "clip"
  EngineSettings test_settings;     // the pre-, post- and retention tests' setting
  // Practice trials on the test setting before the pre-test (a protocol's
  // training_trials), 0..1000: counted as practice, never measured.
  int familiarization_trials = 0;
  // Trials per test: the pre-test and the retention test are optional (0),
  // the post-test is not (>= 1); each <= 100.
  int pre_trials = 3;
  int post_trials = 3;
  int retention_trials = 3;
  std::vector<TransferGroup> groups;  // >= 2

  // Throws std::invalid_argument naming the field, its value and the range.
  void validate() const;
};

struct TransferOptions {
  double rate_Hz = 1000.0;     // 150..2000
  double max_trial_s = 300.0;  // per-trial time limit
  PopulationParams population;
  LearningModel learning;
  // The loop's protections session run gives every trial of the study
  // (protocols::loop_protections: the protocol's force limits among them),
  // so the simulated trials feel them too.
  LoopSafetyConfig protections;
};

enum class TransferPhase : std::uint8_t { kFamiliarization, kPreTest, kTraining, kPostTest, kRetention };
// "familiarization", "pre", "training", "post", "retention"
const char* transfer_phase_name(TransferPhase phase) noexcept;

struct TransferTrial {
  TransferPhase phase = TransferPhase::kPreTest;
  int number = 0;        // 1, 2, ... over the participant's trials (the learning curve's index)
  double time_s = 0.0;   // from the trial's start to the task complete (its loop time)
  bool complete = false;  // false: timed out (time_s is max_trial_s)
  double force_information = 0.0;  // core/sim/force_information.h
};

struct TransferParticipant {
  std::string code;
  int group = 0;  // index into TransferDesign::groups
  std::vector<TransferTrial> trials;
  // Mean time of the test's complete trials [s]; NaN when none completed
  // or the design has no such test.
  double pre_s = 0.0, post_s = 0.0, retention_s = 0.0;
};

struct TransferStudy {
  std::vector<TransferParticipant> participants;  // group by group, in order
  int trials_run = 0;
  int trials_timed_out = 0;
  std::uint64_t updates = 0;
};

// Simulates `per_group` fresh participants in each group of `design`.
// `seed` picks the people and their trials; the same seed gives the same
// study. Throws std::invalid_argument (design, options, per_group outside 1..999).
TransferStudy simulate_transfer_study(const TransferDesign& design, int per_group, std::uint64_t seed,
                                      const TransferOptions& options);

}  // namespace hapticlab::planning
