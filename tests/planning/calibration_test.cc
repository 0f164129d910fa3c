// plan calibrate's effects (planning/calibration.h), on trials whose
// measures are set by hand, and the command on a tiny protocol.
#include "planning/calibration.h"

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/cli_process.h"
#include "protocols/protocol_json.h"
#include "testing/files.h"
#include "testing/test_paths.h"

namespace hapticlab::planning {
namespace {

using ::testing::HasSubstr;

analysis::TrialRecord trial(const std::string& participant, const std::string& setting, double left_p95_N,
                            double right_p95_N, double duration_s) {
  analysis::TrialRecord t;
  t.participant = participant;
  t.task = "dissection";
  t.setting = setting;
  t.window = analysis::TaskWindow{1.0, 1.0 + duration_s};
  t.hands[0].force_p95_N = left_p95_N;
  t.hands[1].force_p95_N = right_p95_N;
  t.hands[0].force_median_N = t.hands[1].force_median_N = 1.0;
  return t;
}

const MeasuredEffect& effect(const std::vector<MeasuredEffect>& all, const std::string& id) {
  for (const auto& e : all)
    if (e.effect.id == id) return e;
  throw std::runtime_error("no effect " + id);
}

// Worked by hand. A: HF p95 values {1, 1} and {1, 3} (two trials, both
// hands) -> median 1; NFF {2, 2, 3, 3} -> 2.5: ratio 2.5. B: HF {2, 2, 2, 2}
// -> 2; NFF {3, 3, 3, 3} -> 3: ratio 1.5. Median of (2.5, 1.5) = 2.
// Hands, every setting pooled: A left {1, 1, 2, 3} / right {1, 3, 2, 3}
// -> 1.5 / 2.5 = 0.6; B left 2.5 / right 2.5 = 1.
TEST(CalibrationTest, RatiosOfEachParticipantsMediansWorkedByHand) {
  analysis::StudyAnalysis a;
  a.trials = {trial("A", "HF", 1, 1, 10), trial("A", "HF", 1, 3, 10), trial("A", "NFF", 2, 2, 11),
              trial("A", "NFF", 3, 3, 11), trial("B", "HF", 2, 2, 20), trial("B", "HF", 2, 2, 20),
              trial("B", "NFF", 3, 3, 20), trial("B", "NFF", 3, 3, 20)};
  const auto effects = measure_effects(a, "HF", "NFF");
  const MeasuredEffect& p95 = effect(effects, "nff_force_p95_dissection_wagner");
  EXPECT_EQ(p95.participants, 2u);
  EXPECT_DOUBLE_EQ(p95.median, 2.0);
  EXPECT_DOUBLE_EQ(p95.share_above_one, 1.0);
  EXPECT_TRUE(p95.consistent);  // >= 2
  const MeasuredEffect& time = effect(effects, "nff_time_dissection_wagner");
  EXPECT_DOUBLE_EQ(time.median, (1.1 + 1.0) / 2.0);  // A 11/10, B 20/20
  EXPECT_TRUE(time.consistent);                      // within 0.9..1.1
  const MeasuredEffect& hands = effect(effects, "hand_force_p95_dissection");
  EXPECT_DOUBLE_EQ(hands.median, (0.6 + 1.0) / 2.0);
  EXPECT_DOUBLE_EQ(hands.share_above_one, 0.0);
  EXPECT_FALSE(hands.consistent);  // the thesis' left hand was higher
  // No clip trials: no clip effects.
  for (const auto& e : effects) EXPECT_EQ(e.effect.task, "dissection");
}

class PlanCalibrateTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("plan_calibrate_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::filesystem::path protocol(const std::string& name, const std::string& second_setting) const {
    const auto settings = std::filesystem::path(HAPTICLAB_SOURCE_DIR) / "examples" / "settings";
    const auto path = dir_ / name;
    std::ofstream(path) << R"({"study": "c", "tasks": ["clip"], "repetitions": {"clip": 1}, "settings": [")"
                        << (settings / "high_fidelity.json").string() << R"(", ")"
                        << (settings / second_setting).string()
                        << R"("], "participants": ["A"], "design": {"type": "complete"}, "seed": 3})";
    return path;
  }
  std::filesystem::path dir_;
};

// Three groups of one participant, on one thread or on three: the same
// population, trial for trial.
TEST_F(PlanCalibrateTest, ThePopulationDoesNotDependOnTheNumberOfThreads) {
  const protocols::Protocol p = protocols::load_protocol_file(protocol("c.json", "no_force_feedback.json"));
  SimulatedStudyOptions options;
  options.max_trial_s = 60.0;  // a clip takes 20-40 s; one that does not end is left out sooner
  const SimulatedPopulation one = simulate_population(p, 3, 9, 1, options, 1, {}, {});
  const SimulatedPopulation three = simulate_population(p, 3, 9, 3, options, 1, {}, {});
  // 3 participants x 2 settings x 1 repetition, a timed-out trial left out
  ASSERT_EQ(one.analysis.trials.size() + static_cast<std::size_t>(one.trials_timed_out), 6u);
  EXPECT_EQ(three.trials_timed_out, one.trials_timed_out);
  ASSERT_EQ(three.analysis.trials.size(), one.analysis.trials.size());
  std::set<std::string> participants;
  for (std::size_t k = 0; k < one.analysis.trials.size(); ++k) {
    const auto& a = one.analysis.trials[k];
    const auto& b = three.analysis.trials[k];
    participants.insert(a.participant);
    EXPECT_EQ(a.participant, b.participant);
    EXPECT_EQ(a.setting, b.setting);
    EXPECT_EQ(a.value(analysis::Measure::kForceP95, 0), b.value(analysis::Measure::kForceP95, 0)) << k;
    EXPECT_EQ(a.value(analysis::Measure::kCompletionTime, 0), b.value(analysis::Measure::kCompletionTime, 0)) << k;
  }
  // Each group's participant keeps its group in its code.
  EXPECT_GE(participants.size(), 2u);
  for (const std::string& code : participants) EXPECT_THAT(code, ::testing::MatchesRegex("s[0-2]/P01"));
}

// The command's table: the clip effects of a clip-only protocol, in calibration.csv.
TEST_F(PlanCalibrateTest, WritesTheTableOfTheEffectsItHasDataFor) {
  const auto p = protocol("c.json", "no_force_feedback.json").string();
  const auto [rc, out] = testing::run_cli(kBinary, "plan calibrate --protocol " + p + " --participants 2 --out " +
                                                       (dir_ / "a").string());
  ASSERT_EQ(rc, 0) << out;
  EXPECT_THAT(out, HasSubstr("clip: No Force Feedback / High Fidelity, 95th-percentile tip force"));
  EXPECT_THAT(out, HasSubstr("published: higher, P = 7E-6 (2 surgeons)"));
  const std::string csv = hapticlab::testing::slurp(dir_ / "a" / "calibration.csv");
  EXPECT_THAT(csv, HasSubstr("id,task,what,published,source,criterion,participants,median_ratio"));
  EXPECT_THAT(csv, HasSubstr("nff_force_p95_clip,clip,"));
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 4);  // the header and the three clip effects
}

TEST_F(PlanCalibrateTest, BadInputIsNamed) {
  const auto p = protocol("f.json", "friction.json").string();
  auto [rc, out] = testing::run_cli(kBinary, "plan calibrate --protocol " + p + " --participants 2 --out " +
                                                 (dir_ / "x").string());
  EXPECT_EQ(rc, 1);
  EXPECT_THAT(out, HasSubstr("no setting displays no force (tip_force_saturation enabled with limit_N 0"));
  EXPECT_FALSE(std::filesystem::exists(dir_ / "x" / "calibration.csv"));
  std::tie(rc, out) = testing::run_cli(kBinary, "plan calibrate --protocol " + p + " --participants 1");
  EXPECT_EQ(rc, 2);
  EXPECT_THAT(out, HasSubstr("--participants"));
}

// The protocol checks of plan calibrate without the CLI: the control and
// the setting that displays no force found by what it does (the second
// setting here, whatever its name), and a protocol without one refused.
TEST_F(PlanCalibrateTest, TheProtocolCheckFindsTheControlAndTheSettingWithoutForce) {
  const auto path = protocol("c.json", "no_force_feedback.json").string();
  const CalibrationSettings found =
      check_calibration_protocol(protocols::load_protocol_file(path), path, 12, 3, SimulatedStudyOptions{});
  EXPECT_EQ(found.control, "High Fidelity");
  EXPECT_EQ(found.no_feedback, "No Force Feedback");
  const auto friction = protocol("f.json", "friction.json").string();
  try {
    (void)check_calibration_protocol(protocols::load_protocol_file(friction), friction, 12, 3, SimulatedStudyOptions{});
    FAIL() << "a protocol without a setting that displays no force was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr(friction + ": no setting displays no force"));
  }
}

// The control is taken by its name but judged by what it does, like No
// Force Feedback: a 'High Fidelity' with friction on is refused by name.
TEST_F(PlanCalibrateTest, AControlThatDegradesSomethingIsRefused) {
  const auto settings = std::filesystem::path(HAPTICLAB_SOURCE_DIR) / "examples" / "settings";
  const auto path = (dir_ / "degraded.json").string();
  std::ofstream(path) << R"({"study": "c", "tasks": ["clip"], "repetitions": {"clip": 1}, "settings": [
      {"name": "High Fidelity", "translation": {"friction": {"dynamic_level_N": 2.0}}}, ")"
                      << (settings / "no_force_feedback.json").string()
                      << R"("], "participants": ["A"], "design": {"type": "complete"}, "seed": 3})";
  try {
    (void)check_calibration_protocol(protocols::load_protocol_file(path), path, 12, 3, SimulatedStudyOptions{});
    FAIL() << "a degraded control was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr(path + ": the control 'High Fidelity' has translation.friction on, but plan "
                                           "calibrate measures every effect against an undegraded control"));
  }
}

TEST(CalibrationCsvTest, OneLinePerEffectWithItsMeasuredRatio) {
  MeasuredEffect e;
  e.effect = published_effects().front();
  e.participants = 7;
  e.median = 1.25;
  e.q1 = 1.0;
  e.q3 = 1.5;
  e.share_above_one = 0.75;
  e.consistent = false;
  const std::string csv = calibration_csv({e});
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 2);
  EXPECT_THAT(csv, HasSubstr("\n" + e.effect.id + "," + e.effect.task + ","));
  EXPECT_THAT(csv, HasSubstr(",7,1.25,1,1.5,0.75,no\n"));
}

}  // namespace
}  // namespace hapticlab::planning
