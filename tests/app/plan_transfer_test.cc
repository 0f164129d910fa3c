// `hapticlab plan power` on a protocol with groups (a transfer design,
// app/plan/plan_transfer.h) through the real binary: the power table per
// task, group size and test, its CSV, JSON on request, the same rows on
// one and two threads, and the options that do not apply refused by name.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "tests/app/cli_process.h"
#include "tests/app/plan_power_fixture.h"
#include "tests/testing/files.h"

namespace hapticlab::app {
namespace {

using ::testing::HasSubstr;

// The shipped transfer study with one short training sitting, so that the
// test stays a few seconds under the sanitizers.
std::filesystem::path small_transfer_protocol(const std::filesystem::path& dir) {
  nlohmann::json p = nlohmann::json::parse(testing::slurp(source_dir() / "examples/protocols/transfer_study.json"));
  for (auto& s : p["settings"]) s = (source_dir() / "examples/protocols" / s.get<std::string>()).string();
  for (auto& phase : p["phases"]) {
    if (phase["phase"] == "training") phase["sessions"] = 1;
    phase["trials"] = {{"dissection", 1}, {"clip", 1}};
  }
  p["training_trials"] = 0;
  const std::filesystem::path out = dir / "transfer.json";
  std::ofstream(out) << p.dump();
  return out;
}

TEST_F(PlanPowerTest, ATransferDesignGetsPowerPerGroupSizeAndTestFromOneRun) {
  protocol_ = small_transfer_protocol(dir_);
  const std::string base = "plan power --protocol " + protocol_.string() +
                           " --rate-hz 250 --studies 2 --seed 3 --force-free-share 0.25 --out ";
  const auto [rc, text] = testing::run_cli(HAPTICLAB_CLI_PATH, base + (dir_ / "a").string() + " --participants 2 --jobs 1");
  ASSERT_EQ(rc, 0) << text;
  EXPECT_THAT(text, HasSubstr("force_free_share 0.25, an assumption, not a fit"));
  // The population's point estimate, said (a within-participant plan samples the model's uncertainty by default).
  EXPECT_THAT(text, HasSubstr("its point estimate (a transfer design's studies do not sample the model's uncertainty"));
  EXPECT_THAT(text, HasSubstr("| dissection | 2 | post | trained on the Falcon |"));
  EXPECT_THAT(text, HasSubstr("| clip | 2 | retention | control |"));
  const std::string csv = testing::slurp(dir_ / "a" / "transfer_power.csv");
  std::istringstream lines(csv);
  std::string line;
  std::vector<std::string> rows;
  while (std::getline(lines, line)) rows.push_back(line);
  ASSERT_EQ(rows.size(), 1u + 2 * 2 * 2);  // header + 2 tasks x (post, retention) x 2 groups against the first
  EXPECT_EQ(rows[0].rfind("task,participants_per_group,test,group,reference,studies,significant,power", 0), 0u);
  EXPECT_EQ(rows[1].rfind("dissection,2,post,trained on the Falcon,trained on High Fidelity,2,", 0), 0u) << rows[1];
  // Beside it, what it was made from.
  const nlohmann::json made = nlohmann::json::parse(testing::slurp(dir_ / "a" / "transfer_power.inputs.json"));
  EXPECT_EQ(made.at("protocol_sha256").get<std::string>().size(), 64u);
  EXPECT_EQ(made.at("seed"), "3");
  EXPECT_EQ(made.at("participants"), nlohmann::json::array({2}));
  EXPECT_EQ(made.at("studies"), 2);
  EXPECT_EQ(made.at("force_free_share"), 0.25);
  EXPECT_EQ(made.at("settings").size(), 2u);  // the shipped transfer study's two: High Fidelity, the Falcon
  EXPECT_THAT(made.at("software").get<std::string>(), HasSubstr("hapticlab "));
  EXPECT_FALSE(made.at("population").get<std::string>().empty());
  // Two threads: the same studies, the same rows; a size given twice is
  // one size (each row once).
  const auto [rc2, text2] =
      testing::run_cli(HAPTICLAB_CLI_PATH, base + (dir_ / "b").string() + " --participants 2,2 --jobs 2");
  ASSERT_EQ(rc2, 0) << text2;
  EXPECT_EQ(testing::slurp(dir_ / "b" / "transfer_power.csv"), csv);
  const auto [rc3, json_text] =
      testing::run_cli_stdout(HAPTICLAB_CLI_PATH, base + (dir_ / "c").string() + " --participants 2 --jobs 2 --json");
  ASSERT_EQ(rc3, 0) << json_text;
  const nlohmann::json j = nlohmann::json::parse(json_text);
  EXPECT_EQ(j.at("force_free_share"), 0.25);
  EXPECT_EQ(j.at("model_uncertainty"), false);
  EXPECT_EQ(j.at("rows").size(), 8u);
}

TEST_F(PlanPowerTest, OptionsThatDoNotApplyToATransferDesignAreRefusedByName) {
  const std::string transfer = "plan power --protocol " + (source_dir() / "examples/protocols/transfer_study.json").string() +
                               " --rate-hz 250 --studies 1 --out " + (dir_ / "t").string();
  auto refused = [](const std::string& args, const std::string& named) {
    const auto [rc, text] = testing::run_cli(HAPTICLAB_CLI_PATH, args);
    EXPECT_NE(rc, 0) << args;
    EXPECT_THAT(text, HasSubstr(named)) << args;
  };
  refused(transfer + " --shard 0/2", "--shard: not for a protocol with groups");
  refused(transfer + " --measure force_p95_N", "--measure: not for a protocol with groups");
  refused(transfer + " --force-free-share 1.5", "--force-free-share");
  refused("plan power --protocol " + (source_dir() / "examples/protocols/thesis_quick.json").string() +
              " --studies 1 --force-free-share 0.5 --out " + (dir_ / "w").string(),
          "--force-free-share: only for a protocol with groups");
  EXPECT_FALSE(std::filesystem::exists(dir_ / "w" / "power.csv"));
}

}  // namespace
}  // namespace hapticlab::app
