// The simulated participant: traits drawn from a seed (deterministic, in
// their documented ranges, mostly right-handed), the start pose, and
// practice that makes the same person on the same task faster.
#include "core/sim/participant.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>

#include <gtest/gtest.h>

#include "core/settings/settings_json.h"
#include "core/sim/dissection_task.h"
#include "core/sim/trial_runner.h"
#include "core/sim/workspace.h"

namespace hapticlab {
namespace {

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

bool same_traits(const ParticipantTraits& a, const ParticipantTraits& b) {
  return same_bits(a.speed, b.speed) && same_bits(a.force_level, b.force_level) &&
         same_bits(a.consistency, b.consistency) &&
         same_bits(a.hand_stiffness_N_per_m, b.hand_stiffness_N_per_m) &&
         same_bits(a.visual_force_gain, b.visual_force_gain) &&
         same_bits(a.haptic_delay_s, b.haptic_delay_s) && same_bits(a.visual_delay_s, b.visual_delay_s) &&
         a.right_handed == b.right_handed && same_bits(a.nondominant_factor, b.nondominant_factor) &&
         same_bits(a.learning_gain, b.learning_gain) && same_bits(a.learning_trials, b.learning_trials);
}

TEST(ParticipantTraitsTest, TheSameSeedGivesTheSamePersonAndAnotherSeedAnother) {
  for (std::uint64_t seed : {0ull, 1ull, 2ull, 12345ull, ~0ull}) {
    EXPECT_TRUE(same_traits(ParticipantTraits::sample(seed), ParticipantTraits::sample(seed))) << seed;
    EXPECT_FALSE(same_traits(ParticipantTraits::sample(seed), ParticipantTraits::sample(seed + 1))) << seed;
  }
}

TEST(ParticipantTraitsTest, TraitsStayInTheirRangesAndOneInTenIsLeftHanded) {
  int right_handed = 0;
  double speed_sum = 0.0;
  constexpr int kN = 2000;
  for (int seed = 1; seed <= kN; ++seed) {
    const ParticipantTraits t = ParticipantTraits::sample(static_cast<std::uint64_t>(seed));
    EXPECT_GE(t.speed, 0.65);
    EXPECT_LE(t.speed, 1.5);
    EXPECT_GE(t.force_level, 0.65);
    EXPECT_LE(t.force_level, 1.5);
    // The rest within physiological bounds (participant.h, hand.h) rather
    // than the exact sampling ranges, which are being tuned: trial-to-trial
    // log-sd below 50 %, arm stiffness of several hundred N/m up to ~1 kN/m,
    // forces seen as smaller than they are, haptic and visual delays of
    // 20-80 ms and 100-300 ms.
    EXPECT_GT(t.consistency, 0.0);
    EXPECT_LT(t.consistency, 0.5);
    EXPECT_GE(t.hand_stiffness_N_per_m, 300.0);
    EXPECT_LE(t.hand_stiffness_N_per_m, 1000.0);
    EXPECT_GT(t.visual_force_gain, 0.3);
    EXPECT_LE(t.visual_force_gain, 1.0);
    EXPECT_GE(t.haptic_delay_s, 0.02);
    EXPECT_LE(t.haptic_delay_s, 0.08);
    EXPECT_GE(t.visual_delay_s, 0.10);
    EXPECT_LE(t.visual_delay_s, 0.30);
    EXPECT_GT(t.visual_delay_s, t.haptic_delay_s) << "vision is the slower cue";
    EXPECT_GT(t.nondominant_factor, 1.0) << "the other hand is the slower one";
    EXPECT_LT(t.nondominant_factor, 2.0);
    right_handed += t.right_handed ? 1 : 0;
    speed_sum += std::log(t.speed);
  }
  // P(right-handed) = 0.9: Binomial(2000, 0.9) has mean 1800 and sd 13.4;
  // ±4 sd.
  EXPECT_NEAR(right_handed, 1800, 54);
  // Speed is a log-normal factor around 1 (log-sd 0.2, clamped): the mean
  // log over 2000 people is within 4·0.2/√2000 = 0.018 of 0.
  EXPECT_NEAR(speed_sum / kN, 0.0, 0.018);
}

TEST(ParticipantTest, StartPoseHoldsBothToolsInTheirTrocarsAimedAtTheWorkArea) {
  for (int i = 0; i < 2; ++i) {
    const DeviceJoints pose = Participant::start_pose(i);
    EXPECT_DOUBLE_EQ(pose[kJointInsertion], 0.005);
    const Eigen::Vector3d tip = tip_world(i, JointVector(pose[0], pose[1], pose[2]));
    const Eigen::Vector3d trocar = kTrocarPosition_m[static_cast<std::size_t>(i)];
    const Eigen::Vector3d aim = (Eigen::Vector3d(0.0, 0.0, -0.11) - trocar).normalized();
    EXPECT_LT((tip - (trocar + 0.005 * aim)).norm(), 1e-12) << i;
    EXPECT_GT(pose[kJointGrip], 0.16) << "jaws open";
  }
}

TEST(ParticipantTest, PracticeMakesTheSamePersonFasterOnTheSameTrial) {
  // The movement-time factor falls from (1 + gain) untrained to ~1 after
  // many trials (gain 0.3..0.7, participant.h); burning time does not
  // shrink with practice, so the whole trial shortens less. Measured over
  // these four people (dissection, high fidelity, trial seed 7; participant
  // model of 9bb2dac; the test prints them): practised (20 trials) /
  // untrained durations 0.67..0.86, mean 0.73. Required: every one faster,
  // and a mean ratio below 0.9.
  const EngineSettings hf =
      load_settings_file(std::string(HAPTICLAB_SOURCE_DIR) + "/examples/settings/high_fidelity.json").engine;
  double ratio_sum = 0.0;
  constexpr int kPeople = 4;
  for (std::uint64_t person = 1; person <= kPeople; ++person) {
    double duration_s[2] = {0.0, 0.0};
    for (int p = 0; p < 2; ++p) {
      SimTrialConfig c;
      c.task = TaskKind::kDissection;
      c.settings = hf;
      c.participant_seed = person;
      c.trial_seed = 7;
      c.practice_trials = p == 0 ? 0 : 20;
      c.publish_samples = false;
      const SimTrialResult r = run_sim_trial(c);
      ASSERT_TRUE(r.task_complete) << "person " << person << " practice " << c.practice_trials;
      duration_s[p] = r.duration_s;
    }
    std::printf("  participant %llu: %.1f s untrained, %.1f s after 20 trials (%.2f)\n",
                static_cast<unsigned long long>(person), duration_s[0], duration_s[1],
                duration_s[1] / duration_s[0]);
    EXPECT_LT(duration_s[1], duration_s[0]) << "person " << person;
    ratio_sum += duration_s[1] / duration_s[0];
  }
  EXPECT_LT(ratio_sum / kPeople, 0.9);
}

TEST(ParticipantTest, ControlUpdatesEvery5MillisecondsWhateverTheLoopRate) {
  // During the first reach the hand's base reference moves on every control
  // update and only then (the first update places it at the tool tip). Over
  // the first 100 ms that is t = 0, 5, ..., 95 ms at 1 and 2 kHz (20
  // moves); at 500 Hz the first update at or after each grid point, t = 0,
  // 6, 10, 16, ... ms (20); and every update at 150 Hz, whose 6.7 ms period
  // is longer than the control period (15).
  struct Case {
    double rate_Hz;
    int expected_moves;
    bool on_grid;  // the loop period divides the control period
  };
  for (const Case c : {Case{1000.0, 20, true}, Case{2000.0, 20, true}, Case{500.0, 20, false},
                       Case{150.0, 15, false}}) {
    SimDevice device;
    for (int i = 0; i < 2; ++i) device.set_position(i, Participant::start_pose(i));
    const DissectionTask task(7);
    Participant participant(ParticipantTraits::sample(3), ParticipantTrial{7, 0}, device, task);
    const DeviceReading reading{};
    const std::array<InstrumentOutput, 2> engine{};
    VeInput ve_input;
    for (int i = 0; i < 2; ++i) {
      const DeviceJoints q = Participant::start_pose(i);
      ve_input.tip_m[static_cast<std::size_t>(i)] = tip_world(i, JointVector(q[0], q[1], q[2]));
    }
    const VeOutput ve_output;
    const double dt_s = 1.0 / c.rate_Hz;
    int moves = 0;
    Eigen::Vector3d last = participant.hand(1).base();
    // The loop's time is a running sum of dt, which lands a rounding error
    // either side of the grid points; 1e-9 s covers it. A control update is
    // due at the first loop update at or after each grid point, i.e. when a
    // grid point lies in (t − dt, t]; a loop slower than the grid acts at
    // every update.
    const double period_s = Participant::kControlPeriod_s;
    const auto grid_index = [&](double t) { return std::floor((t + 1e-9) / period_s); };
    double t_s = 0.0;
    for (int k = 0; t_s < 0.1 - 1e-9; ++k, t_s += dt_s) {
      participant.act({t_s, dt_s, reading, engine, ve_input, ve_output});
      const Eigen::Vector3d base = participant.hand(1).base();
      const bool moved = base != last;
      const bool due = k == 0 || dt_s > period_s || grid_index(t_s) != grid_index(t_s - dt_s);
      EXPECT_EQ(moved, due) << c.rate_Hz << " Hz, t = " << t_s << " (update " << k << ")";
      if (moved) {
        ++moves;
        if (c.on_grid) {
          EXPECT_LT(std::fmod(t_s + 1e-9, period_s), 2e-9) << c.rate_Hz << " Hz: off the grid at t = " << t_s;
        }
      }
      last = base;
    }
    EXPECT_EQ(moves, c.expected_moves) << c.rate_Hz << " Hz";
  }
}

}  // namespace
}  // namespace hapticlab
