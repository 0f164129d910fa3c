// `study create`, `study show` and `session run` through the real binary:
// what the operator sees, and that a blind session never names a setting.
#include <unistd.h>

#include <array>
#include <filesystem>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/cli_process.h"

namespace hapticlab {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

const std::string kBinary = HAPTICLAB_CLI_PATH;

// The eight settings of the quick thesis protocol.
constexpr std::array<const char*, 8> kSettingNames = {
    "High Fidelity", "No Force Feedback", "All Degradations", "Inertia + Backlash",
    "Cogging",       "Friction",          "Inertia",          "Force Saturation"};

class SessionCommandTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("hapticlab_session_command_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    db_ = (dir_ / "study.db").string();
    const auto [status, out] = testing::run_cli(
        kBinary, "study create --protocol " + std::string(HAPTICLAB_SOURCE_DIR) +
                     "/examples/protocols/thesis_quick.json --db " + db_);
    ASSERT_EQ(status, 0) << out;
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
  std::string db_;
};

TEST_F(SessionCommandTest, ShowPrintsTheScheduleAndProgressSummaryOnlyProgress) {
  const auto [status, out] = testing::run_cli(kBinary, "study show --db " + db_);
  ASSERT_EQ(status, 0) << out;
  // Progress per participant (20 + 20 + 10 trials), then every trial.
  EXPECT_THAT(out, HasSubstr("S3                  10        0"));
  EXPECT_THAT(out, HasSubstr("High Fidelity"));
  EXPECT_THAT(out, HasSubstr("planned"));

  const auto [status2, summary] = testing::run_cli(kBinary, "study show --summary --db " + db_);
  ASSERT_EQ(status2, 0) << summary;
  EXPECT_THAT(summary, HasSubstr("S3                  10        0"));
  EXPECT_THAT(summary, Not(HasSubstr("planned")));
  EXPECT_LT(summary.size(), out.size() / 5);
}

TEST_F(SessionCommandTest, BlindSessionNeverNamesTheSettingTheOperatorViewDoes) {
  const auto [status, blind] = testing::run_cli(
      kBinary, "session run --db " + db_ + " --participant S1 --training-trials 0 --max-trials 2 --blind");
  ASSERT_EQ(status, 0) << blind;
  EXPECT_THAT(blind, HasSubstr("S1 trial 1/20"));
  EXPECT_THAT(blind, HasSubstr("S1 trial 2/20"));
  for (const char* name : kSettingNames) EXPECT_THAT(blind, Not(HasSubstr(name))) << name;

  // The operator view names the setting of the trial (S1's third is in the
  // seeded schedule; any of the names will do).
  const auto [status2, operator_view] = testing::run_cli(
      kBinary, "session run --db " + db_ + " --participant S1 --training-trials 0 --max-trials 1");
  ASSERT_EQ(status2, 0) << operator_view;
  EXPECT_THAT(operator_view, HasSubstr("S1 trial 3/20"));
  int named = 0;
  for (const char* name : kSettingNames)
    if (operator_view.find(std::string("[") + name + "]") != std::string::npos) ++named;
  EXPECT_EQ(named, 1) << operator_view;

  // Three trials complete; the rest still planned.
  const auto [status3, summary] = testing::run_cli(kBinary, "study show --summary --db " + db_);
  ASSERT_EQ(status3, 0);
  EXPECT_THAT(summary, HasSubstr("S1                  20        3        0        0       17"));
}

}  // namespace
}  // namespace hapticlab
