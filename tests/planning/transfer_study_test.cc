// A between-group training study on the simulated rig
// (planning/transfer_study.h):
//
// - each participant's trials run in the design's order: pre-test,
//   training blocks, post-test, retention; a control group only tests;
// - with the fitted model (force_free_share 1) what a group trained on
//   does not change its post-test at all, bit for bit: learning only counts
//   trials;
// - with share 0.5, a group trained without force feedback is slower on the
//   post-test than the same people trained with it;
// - bad designs are refused by name.
#include "planning/transfer_study.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "core/settings/settings_json.h"

namespace hapticlab::planning {
namespace {

EngineSettings transfer_settings(const std::string& name) {
  return load_settings_file(std::string(HAPTICLAB_SOURCE_DIR) + "/examples/settings/" + name + ".json").engine;
}

TransferDesign design(const std::string& second_group_training) {
  TransferDesign d;
  d.task = "dissection";
  d.test_settings = transfer_settings("high_fidelity");
  d.pre_trials = d.post_trials = d.retention_trials = 2;
  d.groups.push_back({"control", {}});
  d.groups.push_back({"trained", {{transfer_settings(second_group_training), 8}}});
  return d;
}

TransferOptions options(double share) {
  TransferOptions o;
  o.rate_Hz = 250.0;
  o.learning.force_free_share = share;
  return o;
}

double mean_post(const TransferStudy& s, int group) {
  double sum = 0.0;
  int n = 0;
  for (const TransferParticipant& p : s.participants) {
    if (p.group != group) continue;
    sum += p.post_s;
    ++n;
  }
  return sum / n;
}

TEST(TransferStudyTest, TrialsRunInTheDesignsOrderAndAControlOnlyTests) {
  const TransferStudy s = simulate_transfer_study(design("high_fidelity"), 2, 3, options(1.0));
  ASSERT_EQ(s.participants.size(), 4u);
  EXPECT_EQ(s.trials_run, 2 * (2 + 2 + 2) + 2 * (2 + 8 + 2 + 2));
  const TransferParticipant& control = s.participants[0];
  const TransferParticipant& trained = s.participants[2];
  EXPECT_EQ(control.code, "G1P001");
  EXPECT_EQ(trained.code, "G2P001");
  ASSERT_EQ(control.trials.size(), 6u);
  ASSERT_EQ(trained.trials.size(), 14u);
  const char* expected[] = {"pre", "pre", "training", "training", "training", "training", "training",
                            "training", "training", "training", "post", "post", "retention", "retention"};
  for (std::size_t k = 0; k < trained.trials.size(); ++k) {
    EXPECT_STREQ(transfer_phase_name(trained.trials[k].phase), expected[k]) << k;
    EXPECT_EQ(trained.trials[k].number, static_cast<int>(k) + 1);
    EXPECT_TRUE(trained.trials[k].complete) << k;
  }
  EXPECT_STREQ(transfer_phase_name(control.trials[2].phase), "post");
  // Practice pays: the trained group's post-test is faster than its pre-test.
  for (int i = 2; i < 4; ++i) EXPECT_LT(s.participants[i].post_s, s.participants[i].pre_s) << i;
  // The same seed, the same study.
  const TransferStudy again = simulate_transfer_study(design("high_fidelity"), 2, 3, options(1.0));
  for (std::size_t i = 0; i < s.participants.size(); ++i) EXPECT_EQ(again.participants[i].post_s, s.participants[i].post_s);
}

TEST(TransferStudyTest, TrainingWithoutForceFeedbackTransfersLessOnlyWhenLearningDependsOnForce) {
  const int n = 3;
  const TransferStudy hf1 = simulate_transfer_study(design("high_fidelity"), n, 9, options(1.0));
  const TransferStudy nff1 = simulate_transfer_study(design("no_force_feedback"), n, 9, options(1.0));
  for (int i = n; i < 2 * n; ++i) {
    EXPECT_EQ(hf1.participants[i].post_s, nff1.participants[i].post_s) << i;  // share 1: counts only trials
    EXPECT_GT(hf1.participants[i].trials[2].force_information, 0.9);
    EXPECT_EQ(nff1.participants[i].trials[2].force_information, 0.0);
  }
  const TransferStudy hf = simulate_transfer_study(design("high_fidelity"), n, 9, options(0.5));
  const TransferStudy nff = simulate_transfer_study(design("no_force_feedback"), n, 9, options(0.5));
  std::printf("  post-test mean, share 0.5: HF-trained %.2f s, NFF-trained %.2f s (share 1: %.2f s)\n",
              mean_post(hf, 1), mean_post(nff, 1), mean_post(hf1, 1));
  EXPECT_GT(mean_post(nff, 1), mean_post(hf, 1));
  // The pre-test comes before any training: the same for both.
  for (int i = n; i < 2 * n; ++i) EXPECT_EQ(hf.participants[i].pre_s, nff.participants[i].pre_s) << i;
}

// The protocol's force limits reach every simulated trial, as session run
// applies them: the same study under a 0.2 N insertion limit and 2 mN·m on
// pitch and yaw is another study (the hand feels the limited force), and
// under limits that are the device's own it is the same, bit for bit.
TEST(TransferStudyTest, TheProtocolsForceLimitsAreFelt) {
  const TransferStudy free = simulate_transfer_study(design("high_fidelity"), 2, 5, options(1.0));
  TransferOptions same = options(1.0);
  same.protections.force_limits.peak_force_fraction = 1.0;  // the default: the device's own limits
  const TransferStudy unchanged = simulate_transfer_study(design("high_fidelity"), 2, 5, same);
  TransferOptions strict = options(1.0);
  strict.protections.force_limits.insertion_force_N = 0.2;
  strict.protections.force_limits.pitch_yaw_torque_Nm = 0.002;
  const TransferStudy limited = simulate_transfer_study(design("high_fidelity"), 2, 5, strict);
  int differing = 0;
  for (std::size_t i = 0; i < free.participants.size(); ++i) {
    ASSERT_EQ(free.participants[i].trials.size(), limited.participants[i].trials.size());
    for (std::size_t k = 0; k < free.participants[i].trials.size(); ++k) {
      EXPECT_EQ(unchanged.participants[i].trials[k].time_s, free.participants[i].trials[k].time_s) << i << " " << k;
      if (limited.participants[i].trials[k].time_s != free.participants[i].trials[k].time_s) ++differing;
    }
  }
  std::printf("  trials whose time the limits changed: %d\n", differing);
  EXPECT_GT(differing, 0);
}

TEST(TransferStudyTest, BadDesignsAreRefusedByName) {
  auto refused = [](TransferDesign d, int per_group, const std::string& named) {
    try {
      (void)simulate_transfer_study(d, per_group, 1, options(1.0));
      ADD_FAILURE() << named << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(named), std::string::npos) << e.what();
    }
  };
  TransferDesign one = design("high_fidelity");
  one.groups.pop_back();
  refused(one, 2, "groups is 1 groups, but must be at least 2");
  TransferDesign empty_block = design("high_fidelity");
  empty_block.groups[1].training[0].trials = 0;
  refused(empty_block, 2, "groups[1] (trained).training[0].trials is 0");
  TransferDesign no_test = design("high_fidelity");
  no_test.post_trials = 0;
  refused(no_test, 2, "post_trials is 0, but must be within 1..100");
  TransferDesign many = design("high_fidelity");
  many.pre_trials = 101;
  refused(many, 2, "pre_trials is 101");
  refused(design("high_fidelity"), 0, "participants per group is 0");
  TransferDesign task = design("high_fidelity");
  task.task = "suturing";
  refused(task, 2, "suturing");
  TransferOptions bad = options(1.0);
  bad.learning.force_free_share = 2.0;
  try {
    (void)simulate_transfer_study(design("high_fidelity"), 2, 1, bad);
    ADD_FAILURE() << "share 2 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("learning.force_free_share"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace hapticlab::planning
