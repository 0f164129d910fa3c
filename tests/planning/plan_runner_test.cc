// The plan's study runner (planning/plan_runner.h), without the CLI: the
// same studies stored whatever the number of threads, an interruption that
// stores nothing new, a resumed run that does only what is left, and the
// model's uncertainty reaching the studies (each group's posterior draw).
#include "planning/plan_runner.h"


#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "planning/plan_inputs.h"
#include "protocols/protocol_json.h"
#include "two_setting_plan.h"

namespace hapticlab::planning {
namespace {

namespace fs = std::filesystem;

class PlanRunnerTest : public TwoSettingPlanTest {
 protected:
  PlanRunnerTest() : TwoSettingPlanTest("runner test") {}
  PlanInputs inputs() const {
    return plan_inputs(protocol_, protocol_path_.string(), protocols::read_protocol_text(protocol_path_.string()), 3,
                       {2}, 20, sim_);
  }
  // A study as its updates and every finding's p, to the bit.
  static std::string digest(const StudyOutcome& s) {
    std::string d = std::to_string(s.index) + ":" + std::to_string(s.updates);
    char p[32];
    for (const Finding& f : s.findings) {
      std::snprintf(p, sizeof p, " %.17g", f.p);
      d += p;
    }
    return d;
  }
  // Every stored study's digest, in (participants, index) order.
  std::vector<std::string> digests(const fs::path& db) const {
    PowerStore store(db, inputs(), protocol_);
    std::vector<std::string> out;
    for (const StudyOutcome& s : store.load()) out.push_back(digest(s));
    return out;
  }
};

TEST_F(PlanRunnerTest, TheSameStudiesOnAnyNumberOfThreadsAndAResumedRunDoesWhatIsLeft) {
  const std::vector<std::pair<int, int>> todo = {{2, 0}, {2, 1}, {2, 2}, {2, 3}};
  PlanRunOptions o;
  o.seed = 3;
  o.sim = sim_;
  std::size_t progress_calls = 0;
  o.on_progress = [&](std::size_t, double) { ++progress_calls; };
  {
    PowerStore store(dir_ / "one.db", inputs(), protocol_);
    o.jobs = 1;
    const PlanRunResult r = run_plan_studies(protocol_, todo, store, o);
    EXPECT_EQ(r.stored, 4u);
    EXPECT_GT(r.updates, 0u);
    EXPECT_EQ(store.done().size(), 4u);
  }
  EXPECT_GE(progress_calls, 1u);
  {
    // Two threads, in two runs: the first interrupted before it takes a
    // study (nothing stored), the second does the rest.
    PowerStore store(dir_ / "two.db", inputs(), protocol_);
    o.jobs = 2;
    o.interrupted = [] { return true; };
    EXPECT_EQ(run_plan_studies(protocol_, todo, store, o).stored, 0u);
    o.interrupted = nullptr;
    EXPECT_EQ(run_plan_studies(protocol_, {todo[0], todo[1]}, store, o).stored, 2u);
    EXPECT_EQ(run_plan_studies(protocol_, {todo[2], todo[3]}, store, o).stored, 2u);
  }
  EXPECT_EQ(digests(dir_ / "one.db"), digests(dir_ / "two.db"));
  // The same plan with its protocol given by another path (a Slurm job's
  // working folder): its stored studies load, and are not called edited.
  PlanInputs elsewhere = inputs();
  elsewhere.protocol_file = "elsewhere/protocol.json";
  EXPECT_EQ(PowerStore(dir_ / "one.db", elsewhere, protocol_).load().size(), 4u);
}

TEST_F(PlanRunnerTest, WithTheModelsUncertaintyEachGroupDrawsItsPopulation) {
  // Two posterior draws far apart: the 20 draw groups are spread over
  // them (draw_of_group), so studies 0 and 10 (groups 0 and 10) take draws
  // 0 and 1; each study equals the same study run on its draw as the point
  // population.
  PopulationParams low, high;
  low.visual_gain_mean = 0.3;
  high.visual_gain_mean = 0.95;
  PlanRunOptions o;
  o.seed = 3;
  o.sim = sim_;
  o.draws = {low, high};
  o.jobs = 2;
  {
    PowerStore store(dir_ / "uncertain.db", inputs(), protocol_);
    ASSERT_EQ(run_plan_studies(protocol_, {{2, 0}, {2, 10}}, store, o).stored, 2u);
  }
  const std::vector<std::string> stored = digests(dir_ / "uncertain.db");
  ASSERT_EQ(stored.size(), 2u);
  std::vector<std::uint64_t> updates;
  for (int k : {0, 10}) {
    SimulatedStudyOptions on_draw = sim_;
    on_draw.population = o.draws[draw_of_group(draw_group(k), o.draws.size())];
    const StudyOutcome direct = run_power_study(protocol_, 2, k, 3, on_draw);
    EXPECT_EQ(stored.at(k == 0 ? 0 : 1), digest(direct));
    updates.push_back(direct.updates);
  }
  EXPECT_NE(draw_of_group(draw_group(0), 2), draw_of_group(draw_group(10), 2)) << "both studies took one draw";
}

// What a resumed run of a shard has left: its studies not in the store,
// in order; and the threads for them.
TEST_F(PlanRunnerTest, AResumedShardDoesItsStudiesNotYetStoredOnAtMostOneThreadEach) {
  PlanInputs shard = inputs();  // 2 participants x 20 studies
  shard.shard = 1;
  shard.shards = 3;             // studies 1, 4, 7, ... of the plan
  PowerStore store(dir_ / "shard.db", shard, protocol_);
  PlanRunOptions o;
  o.seed = 3;
  o.sim = sim_;
  ASSERT_EQ(run_plan_studies(protocol_, {{2, 1}, {2, 7}}, store, o).stored, 2u);
  const PlanWork w = plan_work(shard, store);
  EXPECT_EQ(w.total, 7u);
  EXPECT_EQ(w.already, 2u);
  const std::vector<std::pair<int, int>> left = {{2, 4}, {2, 10}, {2, 13}, {2, 16}, {2, 19}};
  EXPECT_EQ(w.todo, left);
  EXPECT_EQ(plan_jobs(3, 10), 3u);
  EXPECT_EQ(plan_jobs(8, 2), 2u);
  EXPECT_EQ(plan_jobs(8, 0), 1u);
  EXPECT_GE(plan_jobs(0, 1000), 2u);
  EXPECT_EQ(plan_jobs(0, 1000) % 2, 0u);
}

}  // namespace
}  // namespace hapticlab::planning
