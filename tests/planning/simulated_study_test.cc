#include "planning/simulated_study.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "db/study_db.h"
#include "protocols/protocol_error.h"
#include "protocols/protocol_json.h"
#include "sessions/session_runner.h"
#include "sessions/study_setup.h"

namespace hapticlab::planning {
namespace {

std::filesystem::path source_dir() {
  if (const char* env = std::getenv("HAPTICLAB_SOURCE_DIR")) return env;
  return HAPTICLAB_SOURCE_DIR;
}

class SimulatedStudyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::temp_directory_path() /
           ("hapticlab_planning_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    const std::filesystem::path settings = source_dir() / "examples" / "settings";
    protocol_path_ = dir_ / "protocol.json";
    // Codes P01, P02 and the seed as resized_protocol makes them, so the
    // protocol run through the database is the simulated one.
    std::ofstream(protocol_path_) << R"({
      "study": "planning test",
      "tasks": ["clip"],
      "repetitions": {"clip": 2},
      "settings": [")" << (settings / "high_fidelity.json").string()
                                  << R"(", ")" << (settings / "no_force_feedback.json").string() << R"("],
      "participants": ["P01", "P02"],
      "design": {"type": "complete"},
      "training_trials": 1,
      "seed": 7
    })";
  }
  void TearDown() override {
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }
  // The protocol as `study create`, `session run` (P01, then P02) and
  // `analyze` give it.
  analysis::StudyAnalysis run_through_database(const std::filesystem::path& db_path,
                                               const SimulatedStudyOptions& options) const {
    {
      db::StudyDb db(db_path);
      sessions::create_study(db, protocol_path_, "test");
    }
    for (const char* code : {"P01", "P02"}) {
      sessions::SessionOptions o;
      o.participant = code;
      o.rate_Hz = options.rate_Hz;
      sessions::run_session(db_path, o);
    }
    return analysis::analyze_study_file(db_path, options.analysis);
  }
  // Both paths at 250 Hz: they must agree at any rate, and the simulation
  // is these tests' time (a quarter of it at the default 1 kHz's, which
  // the sanitizer build runs 4x slower than the release build).
  static SimulatedStudyOptions test_options() {
    SimulatedStudyOptions o;
    o.rate_Hz = 250.0;
    return o;
  }
  std::filesystem::path dir_, protocol_path_;
};

bool same(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

// The whole point of the in-memory study: it is the study `study create`,
// `session run` and `analyze` would give, trial for trial and bit for bit,
// without storing a sample.
TEST_F(SimulatedStudyTest, EqualsTheStudyRunThroughTheDatabase) {
  const std::filesystem::path db_path = dir_ / "study.db";
  const SimulatedStudyOptions options = test_options();
  const analysis::StudyAnalysis stored = run_through_database(db_path, options);

  const SimulatedStudy simulated =
      simulate_study(protocols::load_protocol_file(protocol_path_), 2, 7, options);
  const analysis::StudyAnalysis& mem = simulated.analysis;
  EXPECT_EQ(simulated.trials_run, 8);
  EXPECT_EQ(simulated.training_trials, 2);  // one per participant, one task
  EXPECT_GT(simulated.updates, 8u * 250u);  // more than a second per trial
  EXPECT_EQ(mem.settings, stored.settings);
  EXPECT_EQ(mem.participants, stored.participants);
  ASSERT_EQ(mem.trials.size(), stored.trials.size());
  for (std::size_t i = 0; i < mem.trials.size(); ++i) {
    const analysis::TrialRecord& x = mem.trials[i];
    const analysis::TrialRecord& y = stored.trials[i];
    EXPECT_EQ(x.trial_id, y.trial_id);
    EXPECT_EQ(x.participant, y.participant);
    EXPECT_EQ(x.setting, y.setting);
    EXPECT_EQ(x.repetition, y.repetition);
    EXPECT_EQ(x.problem, y.problem);
    for (int h = 0; h < 2; ++h) {
      for (analysis::Measure m : analysis::kAllMeasures) {
        EXPECT_TRUE(same(x.value(m, h), y.value(m, h)))
            << "trial " << x.trial_id << " hand " << h << " " << analysis::measure_column(m) << ": "
            << x.value(m, h) << " vs " << y.value(m, h);
      }
    }
  }
  ASSERT_EQ(mem.friedman.size(), stored.friedman.size());
  for (std::size_t i = 0; i < mem.friedman.size(); ++i) {
    ASSERT_EQ(mem.friedman[i].test.result.has_value(), stored.friedman[i].test.result.has_value());
    if (mem.friedman[i].test.result) {
      EXPECT_EQ(mem.friedman[i].test.result->p, stored.friedman[i].test.result->p);
    }
  }
}

// A staircase protocol: the in-memory staircase runs the trials `session
// run` would add (same ids, so the same seeds), and ends with the same
// strengths, values and thresholds as the one stored and replayed by analyze.
TEST_F(SimulatedStudyTest, TheStaircaseEqualsTheOneRunThroughTheDatabase) {
  const std::filesystem::path settings = source_dir() / "examples" / "settings";
  protocol_path_ = dir_ / "staircase.json";
  std::ofstream(protocol_path_) << R"({
    "study": "planning staircase", "tasks": ["clip"], "repetitions": {"clip": 1},
    "settings": [")" << (settings / "high_fidelity.json").string() << R"("],
    "staircase": {"settings": {"name": "Insertion friction", "translation": {"friction": {}}},
                  "field": "translation.friction.dynamic_level_N", "measure": "force_p95_N", "change": 0.2,
                  "baseline": "High Fidelity", "start": 0.9, "step": 0.2, "min": 0, "max": 2,
                  "reversals": 4, "max_trials": 6},
    "participants": ["P01", "P02"], "design": {"type": "complete"}, "seed": 7
  })";
  const std::filesystem::path db_path = dir_ / "staircase.db";
  const SimulatedStudyOptions options = test_options();
  const analysis::StudyAnalysis stored = run_through_database(db_path, options);
  const SimulatedStudy simulated = simulate_study(protocols::load_protocol_file(protocol_path_), 2, 7, options);
  const analysis::StudyAnalysis& mem = simulated.analysis;
  ASSERT_EQ(mem.staircases.size(), 2u);
  ASSERT_EQ(stored.staircases.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const analysis::StaircaseRow& x = mem.staircases[i];
    const analysis::StaircaseRow& y = stored.staircases[i];
    EXPECT_EQ(x.participant, y.participant);
    EXPECT_EQ(x.baseline, y.baseline);
    ASSERT_EQ(x.trials.size(), y.trials.size()) << x.participant;
    EXPECT_GE(x.trials.size(), 1u);
    for (std::size_t k = 0; k < x.trials.size(); ++k) {
      EXPECT_EQ(x.trials[k].strength, y.trials[k].strength) << x.participant << " trial " << k;
      EXPECT_EQ(x.trials[k].value, y.trials[k].value) << x.participant << " trial " << k;
    }
    EXPECT_EQ(x.reversals, y.reversals);
    EXPECT_EQ(x.stop_reason, y.stop_reason);
    EXPECT_EQ(x.threshold, y.threshold);
  }
}

TEST_F(SimulatedStudyTest, ResizingCyclesTheProtocolsParticipants) {
  const protocols::Protocol p = protocols::load_protocol_file(source_dir() / "examples/protocols/thesis_as_run.json");
  const protocols::Protocol five = resized_protocol(p, 5, 99);
  ASSERT_EQ(five.participants.size(), 5u);
  EXPECT_EQ(five.participants[0].code, "P01");
  EXPECT_EQ(five.participants[4].code, "P05");
  EXPECT_EQ(five.seed, 99u);
  // Explicit design: P03 takes S3's settings and tasks (dissection only), P04 S1's.
  EXPECT_EQ(five.design.assignments.at("P03"), p.design.assignments.at("S3"));
  EXPECT_EQ(five.participants[2].tasks, p.participants[2].tasks);
  EXPECT_EQ(five.design.assignments.at("P04"), p.design.assignments.at("S1"));
  EXPECT_THROW(resized_protocol(p, 0, 1), std::invalid_argument);
}

// The simulation never knows the setting: the same study with the settings'
// names permuted (each physics under another setting's name) gives every
// trial the same measures, bit for bit. The schedule is by position in the
// protocol, so trial k has the same physics in both; only its label moves.
TEST_F(SimulatedStudyTest, PermutingTheSettingsNamesChangesNoMeasure) {
  const std::filesystem::path settings = source_dir() / "examples" / "settings";
  auto write = [&](const std::string& file, const std::string& a, const std::string& b, const std::string& c) {
    const auto path = dir_ / file;
    auto inline_setting = [&](const std::string& json_file, const std::string& name) {
      nlohmann::json j = nlohmann::json::parse(std::ifstream(settings / json_file));
      j["name"] = name;
      return j.dump();
    };
    std::ofstream(path) << R"({"study": "blind", "tasks": ["clip"], "repetitions": {"clip": 2}, "settings": [)"
                        << inline_setting("high_fidelity.json", a) << ", " << inline_setting("no_force_feedback.json", b)
                        << ", " << inline_setting("friction.json", c)
                        << R"(], "participants": ["P01", "P02"], "design": {"type": "complete"}, "seed": 7})";
    return protocols::load_protocol_file(path);
  };
  const protocols::Protocol named = write("named.json", "High Fidelity", "No Force Feedback", "Friction");
  const protocols::Protocol permuted = write("permuted.json", "Friction", "High Fidelity", "No Force Feedback");
  SimulatedStudyOptions options = test_options();
  options.analysis.control_setting = "High Fidelity";
  const SimulatedStudy x = simulate_study(named, 2, 11, options);
  options.analysis.control_setting = "Friction";  // the high-fidelity physics in the permuted protocol
  const SimulatedStudy y = simulate_study(permuted, 2, 11, options);
  const std::map<std::string, std::string> renamed = {
      {"High Fidelity", "Friction"}, {"No Force Feedback", "High Fidelity"}, {"Friction", "No Force Feedback"}};
  ASSERT_EQ(x.analysis.trials.size(), y.analysis.trials.size());
  ASSERT_EQ(x.analysis.trials.size(), 12u);
  for (std::size_t k = 0; k < x.analysis.trials.size(); ++k) {
    const analysis::TrialRecord& a = x.analysis.trials[k];
    const analysis::TrialRecord& b = y.analysis.trials[k];
    EXPECT_EQ(a.trial_id, b.trial_id);
    EXPECT_EQ(renamed.at(a.setting), b.setting) << k;
    for (analysis::Measure m : analysis::kAllMeasures)
      for (int h = 0; h < 2; ++h) EXPECT_TRUE(same(a.value(m, h), b.value(m, h))) << k << " " << h;
  }
}

}  // namespace
}  // namespace hapticlab::planning
