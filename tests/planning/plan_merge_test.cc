// A plan's results and the merge of its shards (planning/plan_results.h,
// planning/plan_merge.h), without the CLI: the shards of a plan simulated
// apart and merged give the files a one-machine run of the plan writes,
// byte for byte; a merge run again adds nothing; folders that are not the
// shards of one plan, all of them once, are refused by name. And the
// results' tables from studies set by hand: power.csv's rows and the
// comparison's title.
#include "planning/plan_merge.h"


#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "planning/plan_results.h"
#include "planning/plan_runner.h"
#include "planning/power_store.h"
#include "protocols/protocol_json.h"
#include "two_setting_plan.h"

namespace hapticlab::planning {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::string file_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

class PlanShardsMergeTest : public TwoSettingPlanTest {
 protected:
  PlanShardsMergeTest() : TwoSettingPlanTest("merge test") {}
  // The plan (2 participants, 2 studies), shard `shard` of `shards`.
  PlanInputs inputs(int shard, int shards) const {
    PlanInputs p = plan_inputs(protocol_, protocol_path_.string(),
                               protocols::read_protocol_text(protocol_path_.string()), 3, {2}, 2, sim_);
    p.population = "unfitted model test";
    p.shard = shard;
    p.shards = shards;
    return p;
  }
  // Runs the studies of `p` into DIR/name/plan_power.db.
  fs::path run(const std::string& name, const PlanInputs& p) const {
    const fs::path folder = dir_ / name;
    fs::create_directories(folder);
    PowerStore store(folder / "plan_power.db", p, protocol_);
    PlanRunOptions o;
    o.seed = p.seed;
    o.sim = sim_;
    o.jobs = 2;
    EXPECT_EQ(run_plan_studies(protocol_, p.studies_of_shard(), store, o).stored, p.studies_of_shard().size());
    return folder;
  }
  PlanMergeRequest request(std::vector<std::string> shards, const std::string& out) const {
    PlanMergeRequest r;
    r.shards = std::move(shards);
    r.out = (dir_ / out).string();
    r.plots = false;
    return r;
  }
  static std::string refusal(const PlanMergeRequest& r) {
    try {
      (void)merge_plan_shards(r, [](const std::string&) {});
    } catch (const std::exception& e) {
      return e.what();
    }
    return "(no refusal)";
  }
};

TEST_F(PlanShardsMergeTest, TheShardsMergedWriteWhatAOneMachineRunWritesAndARepeatAddsNothing) {
  const std::string s0 = run("s0", inputs(0, 2)).string();
  const std::string s1 = run("s1", inputs(1, 2)).string();
  const fs::path whole = run("whole", inputs(0, 1));
  {
    PowerStore store(whole / "plan_power.db", inputs(0, 1), protocol_);
    const PlanDesign design = check_plan_design(protocol_, protocol_path_.string(), {2}, 3, sim_);
    const PlanResults r = write_plan_results(protocol_, inputs(0, 1), design, store.load(true), whole,
                                             "force_p95_N", false);
    EXPECT_EQ(r.power_csv, whole / "power.csv");
    EXPECT_TRUE(r.figures.empty());
  }
  const PlanMerge m = merge_plan_shards(request({s1, s0}, "merged"), [](const std::string&) {});
  EXPECT_EQ(m.studies, 2u);
  EXPECT_EQ(m.added, 2u);
  EXPECT_EQ(m.already, 0u);
  EXPECT_EQ(m.whole.shards, 1);
  for (const char* f : {"power.csv", "predicted_change.csv", "comparison.md"})
    EXPECT_EQ(file_text(dir_ / "merged" / f), file_text(whole / f)) << f;
  EXPECT_THAT(file_text(dir_ / "merged" / "comparison.md"), HasSubstr("# merge test: predicted change and power"));
  const PlanMerge again = merge_plan_shards(request({s0, s1}, "merged"), [](const std::string&) {});
  EXPECT_EQ(again.added, 0u);
  EXPECT_EQ(again.already, 2u);
  EXPECT_EQ(file_text(dir_ / "merged" / "power.csv"), file_text(whole / "power.csv"));

  // Refused, each by name: a missing shard, a folder twice, a whole plan,
  // --out among the shards.
  EXPECT_THAT(refusal(request({s0}, "m2")), HasSubstr("the plan has 2 shards, and 1/2 is not among the folders given"));
  EXPECT_THAT(refusal(request({s0, s0}, "m2")), HasSubstr("shard folder '" + s0 + "' is named twice"));
  EXPECT_THAT(refusal(request({s0, whole.string()}, "m2")), HasSubstr(": holds a whole plan ("));
  EXPECT_THAT(refusal(request({s0, s1}, "s1")), HasSubstr("is one of the shard folders it merges"));
  EXPECT_THAT(refusal(request({}, "m2")), HasSubstr("no shard folders given"));
  EXPECT_FALSE(fs::exists(dir_ / "m2"));
}

TEST_F(PlanShardsMergeTest, PowerCsvHoldsEachSettingsShareOfSignificantStudies) {
  // Two studies set by hand: No Force Feedback significant in one of them.
  std::vector<StudyOutcome> outcomes(2);
  for (int k = 0; k < 2; ++k) {
    outcomes[k].participants = 2;
    outcomes[k].index = k;
    Finding f;
    f.method = "pairwise";
    f.task = "clip";
    f.setting = "No Force Feedback";
    f.measure = "force_p95_N";
    f.significant = k == 0;
    f.p = k == 0 ? 0.01 : 0.5;
    outcomes[k].findings.push_back(f);
  }
  const PlanDesign design = check_plan_design(protocol_, protocol_path_.string(), {2}, 3, sim_);
  const PlanResults r = write_plan_results(protocol_, inputs(0, 1), design, outcomes, dir_, "force_p95_N", false);
  ASSERT_EQ(r.rows.size(), 1u);
  EXPECT_EQ(r.rows[0].tests, 2);
  EXPECT_EQ(r.rows[0].significant, 1);
  const std::string csv = file_text(dir_ / "power.csv");
  EXPECT_EQ(csv, power_csv_text(r.rows));
  EXPECT_THAT(csv, HasSubstr("participants,method,task,setting,measure,tests,significant,rate,"));
  EXPECT_THAT(csv, HasSubstr("\n2,pairwise,clip,No Force Feedback,force_p95_N,2,1,0.5,"));
  EXPECT_THAT(file_text(dir_ / "comparison.md"), HasSubstr("# merge test: predicted change and power\n\n"));
  EXPECT_TRUE(fs::exists(dir_ / "predicted_change.csv"));
}

}  // namespace
}  // namespace hapticlab::planning
