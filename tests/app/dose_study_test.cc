// A dose-response study through the real binary (issue 19 section 4):
// study create from a protocol with "dose", a session per simulated
// participant, then analyze finds the series in the stored protocol and
// reports its trend, the smallest significant strength and the curves.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/app/cli_process.h"
#include "tests/testing/scratch_dir.h"
#include "tests/testing/files.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

class DoseStudyTest : public ::testing::Test {
 protected:
  static std::pair<int, std::string> cli(const std::string& args) { return testing::run_cli(HAPTICLAB_CLI_PATH, args); }
  hapticlab::testing::ScratchDir scratch_{"hapticlab_dose_"};
  const fs::path dir_ = scratch_.path();
};

TEST_F(DoseStudyTest, AnalyzeReportsTheSeriesItsTrendAndItsCurves) {
  const fs::path protocol = dir_ / "dose.json";
  std::ofstream(protocol) << R"({
    "study": "dose", "tasks": ["clip"], "repetitions": {"clip": 1},
    "settings": [{"name": "High Fidelity"}],
    "dose": {"settings": {"name": "Insertion friction", "translation": {"friction": {}}},
             "field": "translation.friction.dynamic_level_N", "strengths": [0.2, 0.9]},
    "participants": ["P01", "P02"], "design": {"type": "complete"}, "seed": 3})";
  const std::string db = (dir_ / "dose.db").string();
  auto [status, out] = cli("study create --protocol " + protocol.string() + " --db " + db);
  ASSERT_EQ(status, 0) << out;
  for (const char* p : {"P01", "P02"}) {
    std::tie(status, out) = cli("session run --db " + db + " --participant " + p);
    ASSERT_EQ(status, 0) << out;
  }
  const fs::path report = dir_ / "report";
  std::tie(status, out) = testing::run_cli_stdout(HAPTICLAB_CLI_PATH, "analyze --db " + db + " --out " +
                                                                          report.string() + " --no-ks --json");
  ASSERT_EQ(status, 0) << out;
  const nlohmann::json j = nlohmann::json::parse(out);
  const nlohmann::json& dose = j.at("dose_response");
  EXPECT_EQ(dose.at("field"), "translation.friction.dynamic_level_N");
  ASSERT_EQ(dose.at("levels").size(), 3u);
  EXPECT_EQ(dose.at("levels")[0].at("setting"), "High Fidelity");
  EXPECT_EQ(dose.at("levels")[0].at("strength"), 0.0);
  EXPECT_EQ(dose.at("levels")[1].at("setting"), "Insertion friction, dynamic_level_N = 0.2");
  EXPECT_EQ(dose.at("levels")[2].at("strength"), 0.9);
  ASSERT_EQ(dose.at("rows").size(), 5u);  // one task, five measures
  for (const auto& row : dose.at("rows")) {
    EXPECT_EQ(row.at("participants"), 2u) << row;
    // Two participants: the sign-flip p is 0.5 or 1, never significant.
    EXPECT_GE(row.at("trend_p").get<double>(), 0.5) << row;
    EXPECT_TRUE(row.at("smallest_significant_strength").is_null()) << row;
  }
  const std::string md = testing::slurp(report / "report.md");
  EXPECT_THAT(md, HasSubstr("## Dose-response, clip"));
  EXPECT_THAT(md, HasSubstr("| Measure | 0 | 0.2 | 0.9 |"));
  EXPECT_TRUE(fs::exists(report / "figures" / "dose_clip_force_p95_N.svg"));

}

}  // namespace
}  // namespace hapticlab::app
