// `hapticlab plan power` through the real binary: deterministic for a seed
// whatever the thread count, resumable after SIGKILL, and bad input
// refused with the field named.
#include <sqlite3.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "tests/app/cli_process.h"
#include "tests/testing/child_process.h"
#include "tests/testing/files.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

fs::path source_dir() {
  if (const char* env = std::getenv("HAPTICLAB_SOURCE_DIR")) return env;
  return HAPTICLAB_SOURCE_DIR;
}

// Studies stored so far, read through SQLite (read-only), as any reader may.
int stored_studies(const fs::path& db) {
  sqlite3* c = nullptr;
  if (sqlite3_open_v2(db.c_str(), &c, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
    sqlite3_close(c);
    return -1;
  }
  sqlite3_busy_timeout(c, 2000);
  sqlite3_stmt* s = nullptr;
  int n = -1;
  if (sqlite3_prepare_v2(c, "SELECT count(*) FROM study", -1, &s, nullptr) == SQLITE_OK && sqlite3_step(s) == SQLITE_ROW)
    n = sqlite3_column_int(s, 0);
  sqlite3_finalize(s);
  sqlite3_close(c);
  return n;
}

class PlanPowerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("hapticlab_plan_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    protocol_ = write_protocol("tiny.json", "high_fidelity.json");
  }
  void TearDown() override {
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }
  // A small study: one task, 2 repetitions of 2 settings, 2 participants.
  fs::path write_protocol(const std::string& name, const std::string& first_setting) {
    const fs::path settings = source_dir() / "examples" / "settings";
    const fs::path p = dir_ / name;
    std::ofstream(p) << R"({"study": "tiny", "tasks": ["clip"], "repetitions": {"clip": 2}, "settings": [")"
                     << (settings / first_setting).string() << R"(", ")"
                     << (settings / "no_force_feedback.json").string()
                     << R"("], "participants": ["A", "B"], "design": {"type": "complete"}, "seed": 5})";
    return p;
  }
  // The loop at 250 Hz: what these tests show (the same table on any
  // thread count, resumed after a kill or a full disk) does not depend on
  // the rate, and the simulation dominates their time (8x slower under the
  // sanitizers than in release).
  static constexpr const char* kRate = " --rate-hz 250 ";
  std::pair<int, std::string> plan(const std::string& args) {
    return testing::run_cli(HAPTICLAB_CLI_PATH, "plan power --protocol " + protocol_.string() + kRate + args);
  }
  fs::path dir_, protocol_;
};

// A staircase protocol: every simulated participant runs the staircase
// after the baseline; the table says how often it ended with a threshold and
// how far the thresholds spread (issue 19 section 4). The same on 1 and 2
// threads, and resumed from the stored studies.
TEST_F(PlanPowerTest, AStaircaseStudyReportsItsThresholds) {
  nlohmann::json p = nlohmann::json::parse(testing::slurp(source_dir() / "examples/protocols/friction_staircase.json"));
  p["settings"] = {(source_dir() / "examples/settings/high_fidelity.json").string()};
  p["repetitions"]["clip"] = 1;
  p["staircase"]["reversals"] = 4;
  p["staircase"]["max_trials"] = 6;
  protocol_ = dir_ / "staircase.json";
  std::ofstream(protocol_) << p.dump();
  const std::string args = std::string(kRate) + "--participants 2 --studies 2 --no-plots --json --out ";
  const auto [rc, text] = testing::run_cli_stdout(HAPTICLAB_CLI_PATH, "plan power --protocol " + protocol_.string() +
                                                                          " --jobs 1 " + args + (dir_ / "a").string());
  ASSERT_EQ(rc, 0) << text;
  const nlohmann::json j = nlohmann::json::parse(text);
  ASSERT_EQ(j.at("staircase").size(), 1u);
  const nlohmann::json& row = j.at("staircase")[0];
  EXPECT_EQ(row.at("participants"), 2);
  EXPECT_EQ(row.at("studies"), 2);
  EXPECT_EQ(row.at("staircases"), 4);  // 2 studies x 2 participants
  EXPECT_GE(row.at("mean_trials").get<double>(), 1.0);
  EXPECT_LE(row.at("mean_trials").get<double>(), 6.0);  // max_trials
  EXPECT_EQ(row.at("rate").get<double>(), row.at("with_threshold").get<double>() / 4.0);
  // Two threads, and a second run over the same folder (nothing left to simulate): the same table.
  const auto [rc2, text2] = testing::run_cli_stdout(
      HAPTICLAB_CLI_PATH, "plan power --protocol " + protocol_.string() + " --jobs 2 " + args + (dir_ / "b").string());
  ASSERT_EQ(rc2, 0) << text2;
  EXPECT_EQ(nlohmann::json::parse(text2).at("staircase"), j.at("staircase"));
  const auto [rc3, text3] = testing::run_cli_stdout(
      HAPTICLAB_CLI_PATH, "plan power --protocol " + protocol_.string() + " " + args + (dir_ / "a").string());
  ASSERT_EQ(rc3, 0) << text3;
  EXPECT_EQ(nlohmann::json::parse(text3).at("staircase"), j.at("staircase"));
}

TEST_F(PlanPowerTest, TheSameSeedGivesTheSameTableOnAnyNumberOfThreads) {
  // The unfitted model (its four participant tests all computable; under
  // the fitted population one of seed 9's is not): the point is the threads.
  const auto [one_rc, one] = plan("--population unfitted --participants 2 --studies 2 --seed 9 --jobs 1 --no-plots --out " + (dir_ / "one").string());
  ASSERT_EQ(one_rc, 0) << one;
  const auto [two_rc, two] = plan("--population unfitted --participants 2 --studies 2 --seed 9 --jobs 2 --no-plots --out " + (dir_ / "two").string());
  ASSERT_EQ(two_rc, 0) << two;
  const std::string csv = testing::slurp(dir_ / "one" / "power.csv");
  EXPECT_EQ(csv, testing::slurp(dir_ / "two" / "power.csv"));
  EXPECT_THAT(csv, HasSubstr("2,pairwise,clip,No Force Feedback,force_p95_N,2,"));
  EXPECT_THAT(csv, HasSubstr("2,participant,clip,,force_p95_N,4,"));  // 2 studies x 2 participants' Table 3.4 tests
  EXPECT_THAT(one, HasSubstr("2 studies simulated"));
  // Another seed, other studies (2 studies x 5 measures x 3 methods: some rate differs).
  const auto [other_rc, other] = plan("--population unfitted --participants 2 --studies 2 --seed 10 --no-plots --out " + (dir_ / "other").string());
  ASSERT_EQ(other_rc, 0) << other;
  EXPECT_NE(csv, testing::slurp(dir_ / "other" / "power.csv"));
}

TEST_F(PlanPowerTest, AKilledRunResumesAndEndsWithTheSameTable) {
  const fs::path out = dir_ / "killed";
  testing::ChildProcess child({HAPTICLAB_CLI_PATH, "plan", "power", "--protocol", protocol_.string(), "--rate-hz", "250",
                               "--participants", "2", "--studies", "5", "--jobs", "1", "--no-plots", "--out", out.string()},
                              (dir_ / "child.log").string());
  ASSERT_TRUE(testing::wait_until([&] { return fs::exists(out / "plan_power.db") && stored_studies(out / "plan_power.db") >= 2; },
                                  std::chrono::seconds(60)))
      << testing::slurp(dir_ / "child.log");
  child.kill(SIGKILL);
  child.wait();
  const int kept = stored_studies(out / "plan_power.db");
  ASSERT_GE(kept, 2);
  ASSERT_LT(kept, 5) << "the run finished before it was killed; the test proves nothing";
  const auto [rc, text] = plan("--participants 2 --studies 5 --jobs 1 --no-plots --out " + out.string());
  ASSERT_EQ(rc, 0) << text;
  EXPECT_THAT(text, HasSubstr(std::to_string(kept) + " of 5 studies already in"));
  EXPECT_EQ(stored_studies(out / "plan_power.db"), 5);
  const auto [fresh_rc, fresh] = plan("--participants 2 --studies 5 --no-plots --out " + (dir_ / "fresh").string());
  ASSERT_EQ(fresh_rc, 0) << fresh;
  EXPECT_EQ(testing::slurp(out / "power.csv"), testing::slurp(dir_ / "fresh" / "power.csv"));
}

// A copy of the control under another name is found as a null setting;
// its comparisons are false positives, counted per method over the study.
TEST_F(PlanPowerTest, ANullSettingIsFoundAndItsFalsePositivesCounted) {
  const fs::path settings = source_dir() / "examples" / "settings";
  protocol_ = dir_ / "null.json";
  std::ofstream(protocol_) << R"({"study": "null", "tasks": ["clip"], "repetitions": {"clip": 2}, "settings": [")"
                           << (settings / "high_fidelity.json").string()
                           << R"(", {"name": "Copy", "description": "the control again"}, ")"
                           << (settings / "friction.json").string()
                           << R"("], "participants": ["A", "B"], "design": {"type": "complete"}, "seed": 5})";
  const auto [rc, text] = plan("--studies 2 --no-plots --json --out " + (dir_ / "null").string());
  ASSERT_EQ(rc, 0) << text;
  // Not declared in "null_settings": found, and said so.
  EXPECT_THAT(text, HasSubstr("note: 'Copy' has the control's parameters: counted as a null setting"));
  const nlohmann::json j = nlohmann::json::parse(text.substr(text.find('{')));
  EXPECT_EQ(j.at("null_settings"), nlohmann::json::array({"Copy"}));
  std::set<std::string> methods;
  for (const auto& r : j.at("family_wise_false_positives")) {
    methods.insert(r.at("method").get<std::string>());
    EXPECT_EQ(r.at("studies"), 2);
  }
  EXPECT_EQ(methods, (std::set<std::string>{"pairwise", "participant_pairwise"}));
  // The null setting is compared like any other, by both methods.
  int copy_rows = 0;
  for (const auto& r : j.at("rows"))
    if (r.at("setting") == "Copy") ++copy_rows;
  EXPECT_EQ(copy_rows, 2 * 5);  // 2 methods x 5 measures, one task
}

// A full disk while writing the output, for real (a small tmpfs in a
// private mount namespace, as StorageFailureTest does): named, with what is
// kept; the kept studies resume to the table of an undisturbed run.
TEST_F(PlanPowerTest, AFullDiskIsNamedAndTheStoredStudiesResume) {
  if (std::system("unshare -m sh -c 'mount -t tmpfs -o size=64k tmpfs /mnt' >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "mounting a tmpfs needs root in a mount namespace";
  const fs::path mnt = dir_ / "mnt";
  fs::create_directories(mnt);
  const std::string run = std::string(HAPTICLAB_CLI_PATH) + " plan power --protocol " + protocol_.string() + kRate +
                          "--participants 2 --studies 4 --jobs 1 --no-plots --out ";
  // 128 kB: the database and about 3 studies (its WAL grows ~30 kB a study).
  const std::string script = "mount -t tmpfs -o size=128k tmpfs " + mnt.string() + " && " + run + mnt.string() +
                             "/plan; rc=$?; mkdir -p " + (dir_ / "kept").string() + " && cp " + mnt.string() +
                             "/plan/plan_power.db* " + (dir_ / "kept").string() + "/; exit $rc";
  const auto [status, out] = testing::run_cli("unshare", "-m sh -c '" + script + "'");
  EXPECT_EQ(status, 1) << out;
  EXPECT_THAT(out, HasSubstr("disk is full"));
  EXPECT_THAT(out, HasSubstr("studies stored before are kept"));
  const int kept = stored_studies(dir_ / "kept" / "plan_power.db");
  ASSERT_GE(kept, 0) << "the database on the full disk is unreadable";
  ASSERT_LT(kept, 4);
  const auto [rc, text] = testing::run_cli(HAPTICLAB_CLI_PATH, run.substr(run.find("plan power")) + (dir_ / "kept").string());
  ASSERT_EQ(rc, 0) << text;
  const auto [fresh_rc, fresh] = plan("--participants 2 --studies 4 --no-plots --out " + (dir_ / "fresh").string());
  ASSERT_EQ(fresh_rc, 0) << fresh;
  EXPECT_EQ(testing::slurp(dir_ / "kept" / "power.csv"), testing::slurp(dir_ / "fresh" / "power.csv"));
}

// With the shipped fitted population, each study draws its participants'
// population from the fit's posterior (by default), and every power row
// gets a 95 % interval with the model's uncertainty beside the simulation-
// only Wilson interval; off gives the point estimate and no model interval;
// the two are different plans, not mixed in one folder; on without a fit
// is refused with the reason.
TEST_F(PlanPowerTest, ModelUncertaintyDrawsEachStudysPopulationFromTheFit) {
  const std::string args = "--participants 2 --studies 2 --no-plots --out ";
  auto [rc, text] = plan(args + (dir_ / "on").string());
  ASSERT_EQ(rc, 0) << text;
  EXPECT_THAT(text, HasSubstr("each study's population drawn from its posterior (model uncertainty on)"));
  EXPECT_THAT(text, HasSubstr("] model ["));
  const std::string on = testing::slurp(dir_ / "on" / "power.csv");
  EXPECT_THAT(on, HasSubstr(",wilson_low,wilson_high,model_low,model_high\n"));
  EXPECT_THAT(on, ::testing::Not(HasSubstr(",,\n")));  // every row has its model interval
  std::tie(rc, text) = plan("--model-uncertainty off " + args + (dir_ / "off").string());
  ASSERT_EQ(rc, 0) << text;
  EXPECT_THAT(text, HasSubstr("its point estimate (model uncertainty off)"));
  const std::string off = testing::slurp(dir_ / "off" / "power.csv");
  EXPECT_THAT(off, HasSubstr("2,pairwise,clip,No Force Feedback,force_p95_N,2,"));
  EXPECT_THAT(off, HasSubstr(",,\n"));  // no model interval
  // The same folder with the other choice: another plan, refused.
  std::tie(rc, text) = plan("--model-uncertainty off " + args + (dir_ / "on").string());
  EXPECT_EQ(rc, 1);
  EXPECT_THAT(text, AllOf(HasSubstr("holds the studies of another plan"), HasSubstr("model uncertainty on")));
  // Nothing to draw from without a fit.
  std::tie(rc, text) =
      plan("--model-uncertainty on --population unfitted " + args + (dir_ / "unfitted").string());
  EXPECT_EQ(rc, 1);
  EXPECT_THAT(text, HasSubstr("has no posterior draws to draw from; use a fitted population file"));
  EXPECT_FALSE(fs::exists(dir_ / "unfitted" / "plan_power.db"));
}

TEST_F(PlanPowerTest, BadInputIsNamed) {
  auto [rc, text] = plan("--studies 0 --out " + (dir_ / "a").string());
  EXPECT_EQ(rc, 2);
  EXPECT_THAT(text, HasSubstr("--studies"));
  std::tie(rc, text) = plan("--participants 0 --out " + (dir_ / "b").string());
  EXPECT_EQ(rc, 2);
  EXPECT_THAT(text, HasSubstr("--participants"));
  // No setting is a control: named, with the settings.
  protocol_ = write_protocol("no_control.json", "friction.json");
  std::tie(rc, text) = plan("--studies 1 --out " + (dir_ / "c").string());
  EXPECT_EQ(rc, 1);
  EXPECT_THAT(text, AllOf(HasSubstr("no setting is named 'High Fidelity'"), HasSubstr("'Friction'")));
  EXPECT_FALSE(fs::exists(dir_ / "c" / "plan_power.db"));
  // Another protocol into a folder that holds a plan: refused, not mixed.
  protocol_ = dir_ / "tiny.json";
  std::tie(rc, text) = plan("--studies 1 --no-plots --out " + (dir_ / "d").string());
  ASSERT_EQ(rc, 0) << text;
  protocol_ = write_protocol("tiny2.json", "high_fidelity.json");
  std::ofstream(protocol_, std::ios::app) << "\n";  // same study, other text: another hash
  std::tie(rc, text) = plan("--studies 1 --no-plots --out " + (dir_ / "d").string());
  EXPECT_EQ(rc, 1);
  EXPECT_THAT(text, HasSubstr("holds the studies of another plan"));
  // The same protocol at another loop rate is another plan too; a rate out
  // of the loop's range is named.
  protocol_ = dir_ / "tiny.json";
  const std::string tiny = "plan power --protocol " + protocol_.string() + " --studies 1 --no-plots --rate-hz ";
  std::tie(rc, text) = testing::run_cli(HAPTICLAB_CLI_PATH, tiny + "500 --out " + (dir_ / "d").string());
  EXPECT_EQ(rc, 1);
  EXPECT_THAT(text, AllOf(HasSubstr("holds the studies of another plan"), HasSubstr("rate 500 Hz")));
  std::tie(rc, text) = testing::run_cli(HAPTICLAB_CLI_PATH, tiny + "100 --out " + (dir_ / "g").string());
  EXPECT_EQ(rc, 2);
  EXPECT_THAT(text, AllOf(HasSubstr("--rate-hz"), HasSubstr("150")));
  // A declared null setting that is not a copy of the control: named, with
  // where it differs; one that is not a setting: named by the protocol reader.
  const fs::path settings = source_dir() / "examples" / "settings";
  protocol_ = dir_ / "bad_null.json";
  std::ofstream(protocol_) << R"({"study": "n", "tasks": ["clip"], "repetitions": {"clip": 2}, "settings": [")"
                           << (settings / "high_fidelity.json").string() << R"(", ")"
                           << (settings / "friction.json").string()
                           << R"("], "null_settings": ["Friction"], "participants": ["A"], )"
                           << R"("design": {"type": "complete"}, "seed": 5})";
  std::tie(rc, text) = plan("--studies 1 --no-plots --out " + (dir_ / "e").string());
  EXPECT_EQ(rc, 1);
  EXPECT_THAT(text, AllOf(HasSubstr("null_settings names 'Friction', but it is not a copy of the control 'High "
                                    "Fidelity': it differs at "),
                          HasSubstr("friction.enabled"),
                          HasSubstr("null setting has the control's parameters")));
  EXPECT_FALSE(fs::exists(dir_ / "e" / "plan_power.db"));
  protocol_ = dir_ / "unknown_null.json";
  std::ofstream(protocol_) << R"({"study": "n", "tasks": ["clip"], "repetitions": {"clip": 2}, "settings": [")"
                           << (settings / "high_fidelity.json").string()
                           << R"(", {"name": "Copy"}], "null_settings": ["Copy", "Cpoy"], "participants": ["A"], )"
                           << R"("design": {"type": "complete"}, "seed": 5})";
  std::tie(rc, text) = plan("--studies 1 --no-plots --out " + (dir_ / "f").string());
  EXPECT_NE(rc, 0);
  EXPECT_THAT(text, HasSubstr("null_settings[1]"));
  EXPECT_THAT(text, HasSubstr("\"Cpoy\", but is not one of the settings"));
}

}  // namespace
}  // namespace hapticlab::app
