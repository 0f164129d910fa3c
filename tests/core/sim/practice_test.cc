// Learning that depends on the force information the hand received
// (core/sim/practice.h, core/sim/force_information.h):
//
// - the measure: 1 for a device showing the VE's force exactly, 0 for no
//   force feedback, and in between by the worked formula;
// - the effective practice count, and that share 1 is the fitted model's
//   count exactly (bit for bit);
// - on the simulated rig: a High Fidelity trial carries much more force
//   information than a trial with friction, and none under No Force
//   Feedback; and a participant trained on No Force Feedback is slower on
//   the next trial than the same participant trained on High Fidelity,
//   once force_free_share < 1 — and exactly as fast with share 1.
#include "core/sim/practice.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "core/settings/settings_json.h"
#include "core/sim/force_information.h"
#include "core/sim/trial_runner.h"

namespace hapticlab {
namespace {

EngineSettings learner_settings(const std::string& name) {
  return load_settings_file(std::string(HAPTICLAB_SOURCE_DIR) + "/examples/settings/" + name + ".json").engine;
}

TEST(ForceInformationTest, OneWhenShownUpToScaleZeroWithoutForceAndTheWorkedRatioBetween) {
  ForceInformation exact, scaled, none, between, empty, opposite;
  const Eigen::Vector3d a(0.3, 0.0, -0.4), b(0.0, 1.0, 0.0);  // |a|² = 0.25, |b|² = 1, a·b = 0
  exact.add(a, a);
  exact.add(b, b);
  EXPECT_EQ(exact.value(), 1.0);
  scaled.add(0.5 * a, a);  // a device showing half the force: the hand adapts to a scale
  scaled.add(0.5 * b, b);
  EXPECT_NEAR(scaled.value(), 1.0, 1e-15);
  none.add(Eigen::Vector3d::Zero(), a);
  none.add(Eigen::Vector3d::Zero(), b);
  EXPECT_EQ(none.value(), 0.0);
  // Shown: a exactly, then b plus 0.5 N along x (a friction the tissue did
  // not make). Σs·v = 0.25 + 1 = 1.25; Σ|s|² = 0.25 + 1.25 = 1.5;
  // Σ|v|² = 1.25: I = 1.25² / (1.5 · 1.25) = 0.8333...
  between.add(a, a);
  between.add(b + Eigen::Vector3d(0.5, 0.0, 0.0), b);
  EXPECT_NEAR(between.value(), 1.25 / 1.5, 1e-15);
  // Free motion only: nothing to learn from.
  empty.add(Eigen::Vector3d(0.2, 0.0, 0.0), Eigen::Vector3d::Zero());
  EXPECT_EQ(empty.value(), 0.0);
  // A force shown against the tissue's still explains it (R², not a signed
  // correlation): the hand learns the mapping, whichever its sign.
  opposite.add(-a, a);
  EXPECT_NEAR(opposite.value(), 1.0, 1e-15);
}

TEST(PracticeTest, ShareOneCountsEveryTrialExactlyAndOtherwiseWeighsByForceInformation) {
  for (int n : {0, 1, 7, 41}) {
    for (double informed : {0.0, 0.3 * n, static_cast<double>(n)}) {
      EXPECT_EQ(effective_practice_trials({n, informed}, LearningModel{}), static_cast<double>(n));
    }
  }
  // 20 trials, 5 of them worth of force information, half the practice
  // force-free: 0.5·20 + 0.5·5 = 12.5.
  EXPECT_DOUBLE_EQ(effective_practice_trials({20, 5.0}, LearningModel{0.5}), 12.5);
  EXPECT_DOUBLE_EQ(effective_practice_trials({20, 5.0}, LearningModel{0.0}), 5.0);
  for (double bad : {-0.1, 1.5, std::nan("")}) {
    try {
      LearningModel{bad}.validate();
      ADD_FAILURE() << bad << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("learning.force_free_share"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("0..1"), std::string::npos) << e.what();
    }
  }
}

SimTrialConfig trial(const std::string& setting, int practice, double informed, double share) {
  SimTrialConfig c;
  c.task = TaskKind::kDissection;
  c.settings = learner_settings(setting);
  c.participant_seed = 11;
  c.trial_seed = 5;
  c.practice_trials = practice;
  c.force_informed_trials = informed;
  c.learning.force_free_share = share;
  c.rate_Hz = 250.0;
  c.publish_samples = false;
  return c;
}

TEST(PracticeTest, TheRigMeasuresForceInformationAndTrainingWithoutItTeachesLess) {
  const SimTrialResult hf = run_sim_trial(trial("high_fidelity", 0, 0.0, 1.0));
  const SimTrialResult nff = run_sim_trial(trial("no_force_feedback", 0, 0.0, 1.0));
  const SimTrialResult friction = run_sim_trial(trial("friction", 0, 0.0, 1.0));
  ASSERT_TRUE(hf.task_complete && nff.task_complete && friction.task_complete);
  std::printf("  force information: HF %.3f, NFF %.3f, friction %.3f\n", hf.force_information,
              nff.force_information, friction.force_information);
  // Measured at 250 Hz (printed): HF 1.000, NFF exactly 0, friction lower.
  EXPECT_GT(hf.force_information, 0.9);
  EXPECT_EQ(nff.force_information, 0.0);
  EXPECT_LT(friction.force_information, hf.force_information - 0.1);
  EXPECT_GE(friction.force_information, 0.0);

  // The same person after 8 trials trained on HF (8 trials of force
  // information) or on NFF (none): with share 1 the next trial is the same
  // trial, bit for bit; with share 0.5 the NFF-trained one has 4 effective
  // trials instead of 8 and, the trial's seed being the same, takes longer
  // by the practice factor alone.
  const double informed_hf = 8.0 * hf.force_information;
  const SimTrialResult after_hf_1 = run_sim_trial(trial("high_fidelity", 8, informed_hf, 1.0));
  const SimTrialResult after_nff_1 = run_sim_trial(trial("high_fidelity", 8, 0.0, 1.0));
  EXPECT_EQ(after_hf_1.duration_s, after_nff_1.duration_s);
  EXPECT_EQ(after_hf_1.samples, after_nff_1.samples);
  const SimTrialResult after_hf = run_sim_trial(trial("high_fidelity", 8, informed_hf, 0.5));
  const SimTrialResult after_nff = run_sim_trial(trial("high_fidelity", 8, 0.0, 0.5));
  ASSERT_TRUE(after_hf.task_complete && after_nff.task_complete);
  std::printf("  after 8 trials, share 0.5: HF-trained %.2f s, NFF-trained %.2f s (share 1: %.2f s)\n",
              after_hf.duration_s, after_nff.duration_s, after_hf_1.duration_s);
  EXPECT_GT(after_nff.duration_s, after_hf.duration_s)
      << "HF-trained " << after_hf.duration_s << " s, NFF-trained " << after_nff.duration_s << " s";
}

TEST(PracticeTest, TheRigRefusesForceInformedPracticeOutsideItsRange) {
  for (double informed : {-1.0, 21.0}) {
    try {
      (void)run_sim_trial(trial("high_fidelity", 20, informed, 0.5));
      ADD_FAILURE() << informed << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("force_informed_trials"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace hapticlab
