// `hapticlab plan power --shard I/N` and `hapticlab plan merge` through the
// real binary (issue 36 §3): the shards run as separate processes, merged
// they write what one machine writes, byte for byte, and folders that are
// not the shards of one plan are refused by name. tests/slurm/ runs the
// same through a real Slurm job array.
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/app/cli_process.h"
#include "tests/app/plan_power_fixture.h"
#include "tests/testing/files.h"

namespace hapticlab::app {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

class PlanMergeTest : public PlanPowerTest {
 protected:
  // Three studies of 2 participants: one per shard of 3.
  static constexpr const char* kPlan = "--participants 2 --studies 3 ";
  std::pair<int, std::string> merge(const std::string& args) {
    return testing::run_cli(HAPTICLAB_CLI_PATH, "plan merge " + args);
  }
  std::string shard_dirs(int n) const {
    std::string out;
    for (int i = 0; i < n; ++i) out += (dir_ / ("s" + std::to_string(i))).string() + " ";
    return out;
  }
};

TEST_F(PlanMergeTest, ShardsMergedWriteWhatOneMachineWrites) {
  auto [rc, text] = plan(std::string(kPlan) + "--out " + (dir_ / "one").string());
  ASSERT_EQ(rc, 0) << text;
  for (int i = 0; i < 3; ++i) {
    std::tie(rc, text) =
        plan(std::string(kPlan) + "--shard " + std::to_string(i) + "/3 --out " + (dir_ / ("s" + std::to_string(i))).string());
    ASSERT_EQ(rc, 0) << text;
    EXPECT_THAT(text, HasSubstr("shard " + std::to_string(i) + "/3: 1 study simulated"));
    // A shard alone writes no table: its studies are not the plan.
    EXPECT_FALSE(fs::exists(dir_ / ("s" + std::to_string(i)) / "power.csv"));
    EXPECT_EQ(stored_studies(dir_ / ("s" + std::to_string(i)) / "plan_power.db"), 1);
  }
  const std::string out = (dir_ / "merged").string();
  std::tie(rc, text) = merge(shard_dirs(3) + "--out " + out);
  ASSERT_EQ(rc, 0) << text;
  EXPECT_THAT(text, HasSubstr("3 shards merged: 3 studies (3 added now, 0 already in"));
  std::vector<std::string> files = {"power.csv", "comparison.md", "predicted_change.csv"};
  for (const auto& f : fs::directory_iterator(dir_ / "one"))
    if (f.path().extension() == ".svg") files.push_back(f.path().filename().string());
  ASSERT_GT(files.size(), 3u) << "no figure written";
  for (const std::string& f : files)
    EXPECT_EQ(testing::slurp(dir_ / "merged" / f), testing::slurp(dir_ / "one" / f)) << f;

  // Merged again: nothing added, the same files.
  std::tie(rc, text) = merge(shard_dirs(3) + "--out " + out);
  ASSERT_EQ(rc, 0) << text;
  EXPECT_THAT(text, HasSubstr("3 studies (0 added now, 3 already in"));
  EXPECT_EQ(testing::slurp(dir_ / "merged" / "power.csv"), testing::slurp(dir_ / "one" / "power.csv"));

  // Folders that are not all the shards of one plan, each refused by name.
  const auto refused = [&](const std::string& args, const std::vector<std::string>& said) {
    const auto [code, message] = merge(args);
    EXPECT_EQ(code, 1) << args << "\n" << message;
    for (const std::string& s : said) EXPECT_THAT(message, HasSubstr(s)) << args;
  };
  const std::string s0 = (dir_ / "s0").string(), s1 = (dir_ / "s1").string(), s2 = (dir_ / "s2").string();
  refused(s0 + " " + s1 + " --out " + (dir_ / "m").string(), {"the plan has 3 shards, and 2/3 is not among the folders"});
  refused(s0 + " " + s1 + " " + s1 + " --out " + (dir_ / "m").string(), {"shard folder '" + s1 + "' is named twice"});
  refused(shard_dirs(3) + "--out " + s1, {"--out '" + s1 + "' is one of the shard folders it merges"});
  refused(s0 + " " + s1 + " " + (dir_ / "one").string() + " --out " + (dir_ / "m").string(),
          {(dir_ / "one").string() + ": holds a whole plan", "not a shard of one"});
  // Shard 2 of another seed: the same position, another plan.
  std::tie(rc, text) = plan(std::string(kPlan) + "--seed 9 --shard 2/3 --out " + (dir_ / "x2").string());
  ASSERT_EQ(rc, 0) << text;
  refused(s0 + " " + s1 + " " + (dir_ / "x2").string() + " --out " + (dir_ / "m").string(),
          {(dir_ / "x2").string() + ": a shard of another plan", "--seed (1 then, 9 now)"});
  // The protocol changed since the shards ran: its settings are compared as loaded.
  const fs::path changed = write_protocol("changed.json", "friction.json");
  refused(shard_dirs(3) + "--protocol " + changed.string() + " --out " + (dir_ / "m").string(),
          {changed.string() + ": not the protocol the shards were made from", "settings[0] 'High Fidelity'"});
  // A shard's predicted change edited after its run: its study's digest no longer matches.
  fs::copy(dir_ / "s1", dir_ / "d1");
  edit_plan_db(dir_ / "d1" / "plan_power.db", "UPDATE setting_change SET ratio = ratio * 2 WHERE rowid = 1");
  refused(s0 + " " + (dir_ / "d1").string() + " " + s2 + " --out " + (dir_ / "m").string(),
          {(dir_ / "d1" / "plan_power.db").string() + ": study of 2 participants",
           "do not match the SHA-256 stored with it"});
  // A shard cut short (its one study gone): missing, named.
  fs::copy(dir_ / "s2", dir_ / "e2");
  edit_plan_db(dir_ / "e2" / "plan_power.db",
               "DELETE FROM finding; DELETE FROM staircase; DELETE FROM setting_change; DELETE FROM setting_trials; "
               "DELETE FROM study");
  refused(s0 + " " + s1 + " " + (dir_ / "e2").string() + " --out " + (dir_ / "m").string(),
          {(dir_ / "e2" / "plan_power.db").string() + ": the study of 2 participants, number 2 is missing from shard 2/3"});
  EXPECT_FALSE(fs::exists(dir_ / "m" / "power.csv"));
}

// A full disk during a merge: stopped, named, the shards untouched and the
// studies merged so far kept; the same merge again finishes the plan.
TEST_F(PlanMergeTest, AFullDiskStopsTheMergeAndLosesNothing) {
  if (std::system("unshare -m sh -c 'mount -t tmpfs -o size=64k tmpfs /mnt' >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "mounting a tmpfs needs root in a mount namespace";
  const std::string plan6 = "--participants 2 --studies 6 --no-plots ";
  for (int i = 0; i < 3; ++i) {
    const auto [rc, text] = plan(plan6 + "--shard " + std::to_string(i) + "/3 --out " +
                                 (dir_ / ("s" + std::to_string(i))).string());
    ASSERT_EQ(rc, 0) << text;
  }
  std::vector<std::string> before;
  for (int i = 0; i < 3; ++i) before.push_back(testing::slurp(dir_ / ("s" + std::to_string(i)) / "plan_power.db"));
  const fs::path mnt = dir_ / "mnt";
  fs::create_directories(mnt);
  // 96 kB: the WAL index (32 kB), the database and about 2 studies.
  const std::string script = "mount -t tmpfs -o size=96k tmpfs " + mnt.string() + " && " + HAPTICLAB_CLI_PATH +
                             " plan merge " + shard_dirs(3) + "--no-plots --out " + mnt.string() + "/m; rc=$?; mkdir -p " +
                             (dir_ / "kept").string() + " && cp " + mnt.string() + "/m/plan_power.db* " +
                             (dir_ / "kept").string() + "/; exit $rc";
  const auto [status, out] = testing::run_cli("unshare", "-m sh -c '" + script + "'");
  EXPECT_EQ(status, 1) << out;
  EXPECT_THAT(out, AllOf(HasSubstr("disk is full"), HasSubstr("the shards are untouched"),
                         HasSubstr("then run the same merge again")));
  const int kept = stored_studies(dir_ / "kept" / "plan_power.db");
  ASSERT_GE(kept, 0) << "the merged database on the full disk is unreadable";
  ASSERT_LT(kept, 6);
  for (int i = 0; i < 3; ++i)
    EXPECT_EQ(testing::slurp(dir_ / ("s" + std::to_string(i)) / "plan_power.db"), before[static_cast<std::size_t>(i)])
        << "shard " << i << " was written";
  const auto [rc, text] = merge(shard_dirs(3) + "--no-plots --out " + (dir_ / "kept").string());
  ASSERT_EQ(rc, 0) << text;
  EXPECT_THAT(text, HasSubstr("6 studies (" + std::to_string(6 - kept) + " added now, " + std::to_string(kept) +
                              " already in"));
  const auto [one_rc, one] = plan(plan6 + "--out " + (dir_ / "one").string());
  ASSERT_EQ(one_rc, 0) << one;
  EXPECT_EQ(testing::slurp(dir_ / "kept" / "power.csv"), testing::slurp(dir_ / "one" / "power.csv"));
}

TEST_F(PlanMergeTest, AShardIsNamedInItsFolderAndChecked) {
  auto [rc, text] = plan(std::string(kPlan) + "--shard 3/3 --out " + (dir_ / "a").string());
  EXPECT_EQ(rc, 2);  // a usage error
  EXPECT_THAT(text, HasSubstr("--shard: '3/3' is not I/N with 0 <= I < N <= 100000"));
  std::tie(rc, text) = plan(std::string(kPlan) + "--shard 0/4 --out " + (dir_ / "a").string());
  EXPECT_EQ(rc, 1);
  EXPECT_THAT(text, HasSubstr("--shard 0/4: the plan has 3 studies (--participants x --studies), so at most 3 shards"));
  // A folder holds one shard: another shard of the same plan is another plan's folder.
  std::tie(rc, text) = plan(std::string(kPlan) + "--shard 0/3 --out " + (dir_ / "a").string());
  ASSERT_EQ(rc, 0) << text;
  std::tie(rc, text) = plan(std::string(kPlan) + "--shard 1/3 --out " + (dir_ / "a").string());
  EXPECT_EQ(rc, 1);
  EXPECT_THAT(text, AllOf(HasSubstr("--shard (0/3 then, 1/3 now)"), HasSubstr("start a new --out")));
  // A study of another shard in a shard's store.
  edit_plan_db(dir_ / "a" / "plan_power.db", "UPDATE study SET idx = 1");
  std::tie(rc, text) = plan(std::string(kPlan) + "--shard 0/3 --out " + (dir_ / "a").string());
  EXPECT_EQ(rc, 1);
  EXPECT_THAT(text, HasSubstr("it is a study of shard 1/3, not of this run's shard 0/3"));
}

}  // namespace
}  // namespace hapticlab::app
