// A between-group design through the real binary (issue 38 §1, §5): one
// sitting per session, the next refused before its due date (the clock
// moved by HAPTICLAB_TEST_NOW_UNIX_S), the operator's override logged, and
// `study show` giving each participant's group, next phase and due date.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "app/cli_process.h"
#include "db/study_db.h"
#include "tests/testing/test_paths.h"

namespace hapticlab {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// One participant per group; sittings of one clip trial each.
void write_group_protocol(const fs::path& file) {
  const std::string settings = std::string(HAPTICLAB_SOURCE_DIR) + "/examples/settings/";
  std::ofstream(file) << R"({
    "study": "group sessions", "tasks": ["clip"],
    "settings": [")" << settings << R"(high_fidelity.json", ")" << settings << R"(no_force_feedback.json"],
    "groups": [{"name": "trained without force", "training": "No Force Feedback"}, {"name": "control", "training": null}],
    "phases": [
      {"phase": "pre_test", "setting": "High Fidelity", "trials": {"clip": 1}},
      {"phase": "training", "sessions": 2, "min_gap_h": 20, "trials": {"clip": 1}},
      {"phase": "post_test", "setting": "High Fidelity", "min_gap_h": 20, "trials": {"clip": 1}}],
    "participants": ["G1", "G2"], "seed": 5})";
}

fs::path group_test_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / (name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

TEST(GroupSessionTest, OneSittingPerSessionRefusedBeforeItsDueDateUnlessOverriddenAndLogged) {
  const fs::path dir = group_test_dir("hapticlab_group_session");
  write_group_protocol(dir / "groups.json");
  const std::string db_path = (dir / "study.db").string();
  auto [status, out] = testing::run_cli(kBinary, "study create --protocol " + (dir / "groups.json").string() +
                                                     " --db " + db_path);
  ASSERT_EQ(status, 0) << out;
  const auto show = [&] {
    const auto [s, text] = testing::run_cli_stdout(kBinary, "study show --json --db " + db_path);
    EXPECT_EQ(s, 0);
    const nlohmann::json all = nlohmann::json::parse(text);
    for (const auto& p : all["participants"])
      if (p["group"] == "trained without force") return nlohmann::json(p);
    ADD_FAILURE() << text;
    return nlohmann::json();
  };
  const std::string code = show()["code"];
  EXPECT_EQ(show()["next_phase"], "pre_test");
  EXPECT_EQ(show()["next_due_utc"], "now");

  const std::string run = "session run --training-trials 0 --db " + db_path + " --participant " + code;
  std::tie(status, out) = testing::run_cli(kBinary, run);
  ASSERT_EQ(status, 0) << out;
  EXPECT_THAT(out, HasSubstr(": 1 trial run (1 complete"));  // the pre-test alone: one sitting per session
  EXPECT_EQ(show()["next_phase"], "training");
  const std::string due = show()["next_due_utc"];

  // Too early: refused, naming the sitting, its due date and the override.
  std::tie(status, out) = testing::run_cli(kBinary, run);
  EXPECT_NE(status, 0);
  EXPECT_THAT(out, HasSubstr("participant " + code + "'s next sitting (training session 1) is not due before " + due));
  EXPECT_THAT(out, HasSubstr("--override-due-date"));

  // A day later it is due.
  const double a_day_later_s = db::unix_now_s() + 24 * 3600.0;
  std::tie(status, out) =
      testing::run_shell("HAPTICLAB_TEST_NOW_UNIX_S=" + std::to_string(a_day_later_s) + " " + kBinary + " " + run + " 2>&1");
  ASSERT_EQ(status, 0) << out;
  EXPECT_EQ(show()["sittings_done"], 2);

  // The operator overrides: it runs, and the override is in the study.
  std::tie(status, out) = testing::run_cli(kBinary, run + " --override-due-date");
  ASSERT_EQ(status, 0) << out;
  EXPECT_EQ(show()["next_phase"], "post_test");
  db::StudyDb db(db_path);
  const auto actions = db.operator_actions();
  ASSERT_EQ(actions.size(), 1u);
  EXPECT_EQ(actions[0].type, "override_due_date");
  EXPECT_THAT(actions[0].detail, HasSubstr("training session 2 due "));
  EXPECT_EQ(actions[0].participant_code, code);
  fs::remove_all(dir);
}

// The demo runs a group design's sittings one after another on simulated
// time: each started when due, so none is refused and none overridden.
TEST(GroupSessionTest, TheDemoRunsEverySittingOnSimulatedTime) {
  const fs::path dir = group_test_dir("hapticlab_group_demo");
  write_group_protocol(dir / "groups.json");
  const auto [status, out] = testing::run_cli(
      kBinary, "demo --no-plots --protocol " + (dir / "groups.json").string() + " --out " + (dir / "out").string());
  ASSERT_EQ(status, 0) << out;
  EXPECT_THAT(out, HasSubstr("Sessions done: 6 of 6 trials complete"));
  db::StudyDb db((dir / "out" / "study.db").string());
  EXPECT_EQ(db.operator_actions().size(), 0u);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace hapticlab
