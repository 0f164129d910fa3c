#pragma once
// How much a simulated participant has practised, and how much of that
// practice counts: learning that depends on the force information the hand
// received (issue 38 §4).
//
// A trial's movement time carries a practice excess that decays with the
// number of trials done (participant.h: learning_gain, learning_trials).
// Here the count is an effective one: a share of each trial counts whatever
// the hand felt (seeing the tools, moving them: vision and motor sequence),
// and the rest counts in proportion to the trial's force information
// (force_information.h), so that practice on a device that shows the
// tissue's forces badly (no force feedback, friction, cogging) teaches less
// of what a test with true forces asks for.
//
// force_free_share = 1 is the model the population was fitted with
// (docs/simulation.md, "Fitting the population"): every trial counts fully,
// whatever the device. A value below 1 is an assumption, not a fit
// (docs/simulation.md, "Simulated learners"): no published data set this
// project holds gives trial-level learning curves under degraded and true
// forces to fit it to.

namespace hapticlab {

struct LearningModel {
  // Share of a practice trial that counts whatever force the hand felt (no
  // unit), in [0, 1]. 1: every trial counts fully (the fitted model).
  double force_free_share = 1.0;

  // Throws std::invalid_argument naming the field, its value and the range.
  void validate() const;
};

// What a participant has practised before a trial (a task's trials,
// training included).
struct PracticeSoFar {
  int trials = 0;                 // trials done, >= 0
  // The same trials, each weighted by its force information in [0, 1]
  // (so 0 <= force_informed_trials <= trials).
  double force_informed_trials = 0.0;
};

// The effective number of practice trials: share·trials + (1 − share)·
// force_informed_trials. With share 1 this is `trials` exactly, so the
// fitted model's numbers stay bit for bit.
double effective_practice_trials(const PracticeSoFar& practice, const LearningModel& model) noexcept;

}  // namespace hapticlab
