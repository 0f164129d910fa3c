// A between-group design's analysis from a study's trials
// (analysis/study/group_design.h), on the shipped transfer_study.json with
// completion times made up so the answer is known: everybody takes 40 s at
// the pre-test; trained groups 30 s at the post-test and retention, the
// control 38 s; training trials fall 1 s per trial from 39 s.
#include "analysis/study/group_design.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>

#include "analysis/stats/data_error.h"
#include "protocols/group_assignment.h"
#include "protocols/protocol_json.h"
#include "protocols/sittings.h"

namespace hapticlab::analysis {
namespace {

StudyAnalysis made_up_study() {
  StudyAnalysis a;
  a.group_design =
      protocols::load_protocol_file(std::string(HAPTICLAB_SOURCE_DIR) + "/examples/protocols/transfer_study.json");
  const protocols::Protocol& p = *a.group_design;
  const std::vector<std::size_t> groups = protocols::assign_groups(p, "test");
  std::int64_t id = 0;
  for (std::size_t i = 0; i < p.participants.size(); ++i) {
    const bool control = !p.transfer->groups[groups[i]].training_setting;
    int position = 0, training = 0;
    const std::vector<protocols::Sitting> sittings = protocols::group_sittings(p, groups[i]);
    for (std::size_t s = 0; s < sittings.size(); ++s) {
      for (int k = 0; k < sittings[s].trials.at("dissection"); ++k) {
        TrialRecord t;
        t.trial_id = ++id;
        t.participant = p.participants[i].code;
        t.task = "dissection";
        t.status = "complete";
        t.block = static_cast<int>(s) + 1;
        t.position = ++position;
        double time_s = 40.0;
        if (sittings[s].phase == protocols::PhaseKind::kTraining) time_s = 39.0 - training++;
        if (sittings[s].phase == protocols::PhaseKind::kPostTest ||
            sittings[s].phase == protocols::PhaseKind::kRetention)
          time_s = control ? 38.0 : 30.0;
        t.window = TaskWindow{100.0, 100.0 + time_s};
        a.trials.push_back(t);
      }
    }
  }
  return a;
}

TEST(GroupDesignTest, TrialsArePlacedByGroupAndSittingAndGroupsComparedOnTheirChange) {
  const std::vector<TaskGroupAnalysis> tasks = analyze_group_design(made_up_study());
  ASSERT_EQ(tasks.size(), 2u);
  const TaskGroupAnalysis& d = tasks[0];
  EXPECT_EQ(d.task, "dissection");
  EXPECT_TRUE(tasks[1].table.participants.empty());  // no clip trials were made up: named, not thrown
  EXPECT_NE(tasks[1].learning_refusal.find("no participant has trials in phase 'training'"), std::string::npos);
  EXPECT_FALSE(tasks[1].transfer_refusal.empty());
  ASSERT_EQ(d.table.participants.size(), 12u);
  for (const learning::ParticipantTrials& person : d.table.participants) {
    const bool control = person.group == "control";
    EXPECT_EQ(person.phases.at(learning::Phase::kPre).value.size(), 2u);
    EXPECT_EQ(person.phases.count(learning::Phase::kTraining), control ? 0u : 1u) << person.participant;
    if (!control) {
      const learning::PhaseTrials& training = person.phases.at(learning::Phase::kTraining);
      ASSERT_EQ(training.value.size(), 15u);  // 5 sittings x 3
      EXPECT_EQ(training.trial.front(), 1.0);
      EXPECT_EQ(training.value.front(), 39.0);
      EXPECT_EQ(training.value.back(), 25.0);
    }
  }
  ASSERT_TRUE(d.transfer) << d.transfer_refusal;
  const transfer::GroupComparison& post = d.transfer->comparisons.at(0);
  EXPECT_EQ(post.outcome, "post-pre");
  for (std::size_t g = 0; g < post.groups.size(); ++g)
    EXPECT_EQ(post.median_change[g], post.groups[g] == "control" ? -2.0 : -10.0) << post.groups[g];
  EXPECT_EQ(d.transfer->reference, "trained on High Fidelity");
  EXPECT_EQ(d.transfer->comparisons.size(), 2u);  // and retention-pre
  // Learning curves over the training phase: the 8 trained participants.
  EXPECT_EQ(d.learning.participants.size(), 8u);

  const std::filesystem::path out = std::filesystem::temp_directory_path() / ("hl_group_design_" + std::to_string(::getpid()));
  std::filesystem::create_directories(out);
  const GroupDesignFiles files = write_group_design(tasks, out, {});
  std::ifstream md(files.markdown);
  const std::string text((std::istreambuf_iterator<char>(md)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("## dissection"), std::string::npos);
  EXPECT_NE(text.find("post-pre:"), std::string::npos);
  EXPECT_NE(text.find("No learning curves: learning curves: no participant has trials"), std::string::npos);
  EXPECT_EQ(files.written.size(), 1u + 2 * 2);  // transfer.md, and per task its trials and curves CSV
  for (const auto& f : files.written) EXPECT_TRUE(std::filesystem::exists(f)) << f;
  std::filesystem::remove_all(out);
}

TEST(GroupDesignTest, ATrialOutsideItsParticipantsSittingsIsRefusedByName) {
  StudyAnalysis a = made_up_study();
  a.trials.back().block = 99;
  try {
    (void)analyze_group_design(a);
    ADD_FAILURE() << "a trial in sitting 99 was placed";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("is in sitting 99, but"), std::string::npos) << e.what();
  }
  a.group_design.reset();
  EXPECT_TRUE(analyze_group_design(a).empty());  // a within-participant study: nothing to do here
}

}  // namespace
}  // namespace hapticlab::analysis
