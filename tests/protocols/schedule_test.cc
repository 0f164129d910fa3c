#include "protocols/schedule.h"

#include <algorithm>
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "protocols/protocol_error.h"

namespace hapticlab::protocols {
namespace {

// A protocol built in code: `settings` named S0..S{n-1}, both tasks.
Protocol make_protocol(std::size_t settings, std::size_t participants, std::uint64_t seed, int dissection_reps = 3,
                       int clip_reps = 9) {
  Protocol p;
  p.study = "schedule test";
  p.tasks = {Task::kDissection, Task::kClip};
  p.repetitions = {{Task::kDissection, dissection_reps}, {Task::kClip, clip_reps}};
  for (std::size_t i = 0; i < settings; ++i) {
    ProtocolSetting s;
    s.settings.name = "Setting " + std::to_string(i);
    s.source = "inline";
    p.settings.push_back(s);
  }
  for (std::size_t i = 0; i < participants; ++i) {
    p.participants.push_back({"P" + std::to_string(i + 1), p.tasks, 0});
  }
  p.seed = seed;
  return p;
}

std::vector<std::string> setting_sequence(const ParticipantPlan& pp) {
  std::vector<std::string> out;
  for (const auto& t : pp.trials) out.push_back(t.setting);
  return out;
}

TEST(ScheduleTest, SameSeedSameScheduleDifferentSeedDifferent) {
  const StudyPlan a = make_study_plan(make_protocol(5, 4, 11));
  const StudyPlan b = make_study_plan(make_protocol(5, 4, 11));
  const StudyPlan c = make_study_plan(make_protocol(5, 4, 12));
  ASSERT_EQ(a.participants.size(), 4u);
  for (std::size_t p = 0; p < 4; ++p) {
    EXPECT_EQ(setting_sequence(a.participants[p]), setting_sequence(b.participants[p]));
    EXPECT_EQ(a.participants[p].task_order, b.participants[p].task_order);
  }
  bool any_difference = false;
  for (std::size_t p = 0; p < 4; ++p) {
    any_difference = any_difference || setting_sequence(a.participants[p]) != setting_sequence(c.participants[p]);
  }
  EXPECT_TRUE(any_difference);
}

TEST(ScheduleTest, TrialFieldsAreConsistent) {
  const StudyPlan plan = make_study_plan(make_protocol(4, 3, 5, 3, 9));
  for (const ParticipantPlan& pp : plan.participants) {
    ASSERT_EQ(pp.trials.size(), 4u * (3 + 9));
    std::map<std::pair<Task, std::size_t>, int> seen;
    for (std::size_t i = 0; i < pp.trials.size(); ++i) {
      const PlannedTrial& t = pp.trials[i];
      EXPECT_EQ(t.participant, pp.code);
      EXPECT_EQ(t.position, static_cast<int>(i) + 1);
      const int expected_repetition = ++seen[std::make_pair(t.task, t.setting_index)];
      EXPECT_EQ(t.repetition, expected_repetition);
      EXPECT_EQ(t.block, t.repetition) << "one occurrence per block";
      EXPECT_EQ(t.setting, "Setting " + std::to_string(t.setting_index));
    }
    // Tasks are contiguous, in the participant's task order.
    EXPECT_EQ(pp.trials.front().task, pp.task_order.front());
    EXPECT_EQ(pp.trials.back().task, pp.task_order.back());
  }
}

TEST(ScheduleTest, EveryBlockHoldsEverySettingOnce) {
  for (std::uint64_t seed = 0; seed < 50; ++seed) {
    const StudyPlan plan = make_study_plan(make_protocol(5, 3, seed));
    for (const ParticipantPlan& pp : plan.participants) {
      std::map<std::pair<Task, int>, std::multiset<std::size_t>> blocks;
      for (const auto& t : pp.trials) blocks[{t.task, t.block}].insert(t.setting_index);
      EXPECT_EQ(blocks.size(), 3u + 9u);
      for (const auto& [key, settings] : blocks) {
        EXPECT_EQ(settings, (std::multiset<std::size_t>{0, 1, 2, 3, 4})) << "seed " << seed;
      }
    }
  }
}

TEST(ScheduleTest, NeverMoreThanTwoInARowForManySeeds) {
  int max_seen = 0;
  for (std::uint64_t seed = 0; seed < 300; ++seed) {
    // Few settings make boundary repeats common: the hardest case for the rule.
    const StudyPlan plan = make_study_plan(make_protocol(2 + seed % 4, 2, seed));
    for (const ParticipantPlan& pp : plan.participants) {
      const int run = longest_run(pp.trials);
      EXPECT_LE(run, kMaxRun) << "seed " << seed << " participant " << pp.code;
      max_seen = std::max(max_seen, run);
    }
  }
  // Blocks do allow 2 in a row at a boundary; if that never happened the
  // shuffles would not be random.
  EXPECT_EQ(max_seen, 2);
}

TEST(ScheduleTest, LongestRunCountsConsecutiveTrials) {
  auto trial = [](std::size_t s) {
    PlannedTrial t;
    t.setting_index = s;
    return t;
  };
  EXPECT_EQ(longest_run({}), 0);
  EXPECT_EQ(longest_run({trial(1)}), 1);
  EXPECT_EQ(longest_run({trial(1), trial(2), trial(2), trial(2), trial(1)}), 3);
}

TEST(ScheduleTest, OneSettingBlocksAreRefusedBeyondTwo) {
  Rng rng(1);
  EXPECT_EQ(block_randomized_order(1, 2, rng), (std::vector<std::size_t>{0, 0}));
  EXPECT_THROW(block_randomized_order(1, 3, rng), std::invalid_argument);
  EXPECT_THROW(block_randomized_order(0, 1, rng), std::invalid_argument);
  // And a protocol giving a participant a single setting is refused outright.
  Protocol p = make_protocol(3, 1, 1);
  p.design.type = DesignType::kExplicit;
  p.design.assignments = {{"P1", {"Setting 0"}}};
  EXPECT_THROW(make_study_plan(p), ProtocolError);
}

TEST(ScheduleTest, TaskOrderIsCounterbalancedInPairs) {
  for (std::uint64_t seed = 0; seed < 40; ++seed) {
    const Protocol p = make_protocol(3, 9, seed);
    const auto orders = counterbalanced_task_orders(p);
    ASSERT_EQ(orders.size(), 9u);
    int dissection_first = 0;
    for (std::size_t i = 0; i < orders.size(); ++i) {
      ASSERT_EQ(orders[i].size(), 2u);
      EXPECT_NE(orders[i][0], orders[i][1]);
      if (orders[i][0] == Task::kDissection) ++dissection_first;
      // Every prefix balanced within one; each pair split.
      const int n = static_cast<int>(i) + 1;
      EXPECT_LE(std::abs(2 * dissection_first - n), 1) << "seed " << seed << " after " << n;
      if (i % 2 == 1) {
        EXPECT_NE(orders[i][0], orders[i - 1][0]);
      }
    }
  }
  // The seed decides which of a pair starts with which task.
  std::set<Task> first_of_first_pair;
  for (std::uint64_t seed = 0; seed < 20; ++seed) {
    first_of_first_pair.insert(counterbalanced_task_orders(make_protocol(3, 2, seed))[0][0]);
  }
  EXPECT_EQ(first_of_first_pair.size(), 2u);
}

TEST(ScheduleTest, SingleTaskParticipantsKeepTheirTaskAndDoNotBreakThePairs) {
  Protocol p = make_protocol(3, 5, 3);
  p.participants[1].tasks = {Task::kDissection};
  const auto orders = counterbalanced_task_orders(p);
  EXPECT_EQ(orders[1], std::vector<Task>{Task::kDissection});
  // Participants 0 and 2 form the first pair, 3 and 4 the second.
  EXPECT_NE(orders[0][0], orders[2][0]);
  EXPECT_NE(orders[3][0], orders[4][0]);
}

TEST(ScheduleTest, AParticipantsScheduleDoesNotDependOnOtherParticipants) {
  const StudyPlan small = make_study_plan(make_protocol(4, 2, 99));
  const StudyPlan large = make_study_plan(make_protocol(4, 6, 99));
  EXPECT_EQ(setting_sequence(small.participants[0]), setting_sequence(large.participants[0]));
  EXPECT_EQ(setting_sequence(small.participants[1]), setting_sequence(large.participants[1]));
}

TEST(ScheduleTest, ParticipantViewNeverNamesTheSetting) {
  const StudyPlan plan = make_study_plan(make_protocol(5, 2, 8));
  for (const ParticipantPlan& pp : plan.participants) {
    const auto view = participant_view(pp);
    ASSERT_EQ(view.size(), pp.trials.size());
    std::map<std::size_t, std::string> label_of_setting;
    std::map<std::string, std::size_t> setting_of_label;
    for (std::size_t i = 0; i < view.size(); ++i) {
      EXPECT_EQ(view[i].position, pp.trials[i].position);
      EXPECT_EQ(view[i].task, pp.trials[i].task);
      EXPECT_EQ(view[i].condition.find("Setting"), std::string::npos);
      // One label per setting and one setting per label.
      auto [it, fresh] = label_of_setting.emplace(pp.trials[i].setting_index, view[i].condition);
      EXPECT_EQ(it->second, view[i].condition);
      auto [jt, fresh2] = setting_of_label.emplace(view[i].condition, pp.trials[i].setting_index);
      EXPECT_EQ(jt->second, pp.trials[i].setting_index);
    }
    EXPECT_EQ(label_of_setting.size(), 5u);
  }
  // Labels are shuffled per participant: over many seeds, setting 0 is not
  // always "A".
  std::set<std::string> labels_of_setting0;
  for (std::uint64_t seed = 0; seed < 20; ++seed) {
    labels_of_setting0.insert(make_study_plan(make_protocol(5, 1, seed)).participants[0].condition_labels[0]);
  }
  EXPECT_GT(labels_of_setting0.size(), 1u);
}

TEST(ScheduleTest, PlansCarryTheFullSettings) {
  Protocol p = make_protocol(3, 1, 4);
  p.settings[2].settings.engine.translation.friction.enabled = true;
  p.settings[2].settings.engine.translation.friction.dynamic_level = 0.45;
  const StudyPlan plan = make_study_plan(p);
  const ParticipantPlan& pp = plan.participants[0];
  ASSERT_EQ(pp.settings.size(), 3u);
  EXPECT_EQ(pp.settings[2].name, "Setting 2");
  EXPECT_TRUE(pp.settings[2].engine.translation.friction.enabled);
  EXPECT_DOUBLE_EQ(pp.settings[2].engine.translation.friction.dynamic_level, 0.45);
}

TEST(ScheduleTest, InvalidProtocolIsRefused) {
  Protocol p = make_protocol(3, 2, 1);
  p.participants[1].code = "P1";
  try {
    make_study_plan(p);
    FAIL() << "duplicate code accepted";
  } catch (const ProtocolError& e) {
    EXPECT_EQ(e.field(), "participants[1].code");
  }
}

// Golden schedule: pinned from an independent implementation of rng.h and
// the block rule (a short Python transcription), so a change in any draw,
// stream key or loop order shows up here on every platform.
TEST(ScheduleTest, GoldenScheduleForSeed2004) {
  Protocol p = make_protocol(3, 2, 2004, 2, 2);
  const StudyPlan plan = make_study_plan(p);
  std::vector<std::string> got;
  for (const ParticipantPlan& pp : plan.participants) {
    std::string s = pp.code + ":";
    for (const auto& t : pp.trials) s += std::string(" ") + (t.task == Task::kDissection ? "d" : "c") +
                                         std::to_string(t.setting_index);
    got.push_back(s);
  }
  const std::vector<std::string> golden{
      "P1: c2 c0 c1 c1 c0 c2 d0 d1 d2 d0 d2 d1",
      "P2: d2 d1 d0 d0 d2 d1 c1 c0 c2 c2 c0 c1",
  };
  EXPECT_EQ(got, golden);
}

}  // namespace
}  // namespace hapticlab::protocols
