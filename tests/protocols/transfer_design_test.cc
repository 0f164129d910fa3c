// Between-group training designs (issue 38 §1, §5): groups randomized in
// stratified blocks, phases turned into sittings with due dates, and every
// bad input refused by name.
#include <algorithm>
#include <filesystem>
#include <map>
#include <set>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "protocols/group_assignment.h"
#include "protocols/protocol_json.h"
#include "protocols/schedule.h"
#include "protocols/sittings.h"
#include "tests/protocols/protocol_failure.h"

namespace hapticlab::protocols {
namespace {

using ::testing::HasSubstr;
using nlohmann::json;

// A function, not a global: a global built from kExampleProtocolsDir (an
// inline variable of another header) can be initialized before it, and was
// under clang's sanitizer build (an empty directory, so a relative path).
std::filesystem::path example_path() { return testing::kExampleProtocolsDir / "transfer_study.json"; }

json example_json() { return json::parse(read_protocol_text(example_path())); }

testing::Failure transfer_failure_of(const json& j) { return testing::protocol_failure(j, testing::kExampleProtocolsDir); }

TEST(TransferDesignTest, ExampleRandomizesInStratifiedBlocksAndPlansSittings) {
  const Protocol p = load_protocol_file(example_path());
  ASSERT_TRUE(p.transfer.has_value());
  ASSERT_EQ(p.transfer->groups.size(), 3u);
  const auto groups = assign_groups(p, "test");
  EXPECT_EQ(groups, assign_groups(p, "test"));  // seeded: the same every time

  // Within each stratum (6 novices, 6 intermediates), 2 per group.
  std::map<std::string, std::map<std::size_t, int>> per_stratum;
  for (std::size_t i = 0; i < p.participants.size(); ++i)
    ++per_stratum[p.participants[i].attributes.at("experience")][groups[i]];
  ASSERT_EQ(per_stratum.size(), 2u);
  for (const auto& [stratum, counts] : per_stratum)
    for (std::size_t g = 0; g < 3; ++g) EXPECT_EQ(counts.count(g) ? counts.at(g) : 0, 2) << stratum << " group " << g;

  // Another seed, another randomization (the stream is the seed's).
  Protocol other = p;
  other.seed = 39;
  EXPECT_NE(assign_groups(other, "test"), groups);

  const StudyPlan plan = make_study_plan(p);
  for (const ParticipantPlan& pp : plan.participants) {
    const Group& g = p.transfer->groups[pp.group];
    EXPECT_EQ(pp.group_name, g.name);
    // Sittings: pre-test, 5 training unless control, post-test, retention.
    const int sittings = g.training_setting ? 8 : 3;
    EXPECT_EQ(pp.trials.back().sitting, sittings) << pp.code;
    const int per_test = 2 + 3;
    const int expected = 3 * per_test + (g.training_setting ? 5 * (3 + 6) : 0);
    EXPECT_EQ(static_cast<int>(pp.trials.size()), expected) << pp.code;
    for (const PlannedTrial& t : pp.trials) {
      const bool training = t.sitting >= 2 && t.sitting <= 6 && g.training_setting;
      EXPECT_EQ(t.setting, training ? *g.training_setting : std::string("High Fidelity")) << pp.code << " " << t.position;
    }
    // Blinding: what the participant sees names neither setting nor group.
    for (const BlindedTrial& b : participant_view(pp)) {
      EXPECT_EQ(b.condition.find("Falcon"), std::string::npos);
      EXPECT_EQ(b.condition.find("Fidelity"), std::string::npos);
    }
  }
}

TEST(TransferDesignTest, BadDesignsAreRefusedByName) {
  {  // a declared group size of 0
    json j = example_json();
    for (auto& g : j["groups"]) g["size"] = 6;
    j["groups"][2]["size"] = 0;
    const auto f = transfer_failure_of(j);
    EXPECT_EQ(f.field, "groups[2].size");
    EXPECT_THAT(f.message, HasSubstr("\"control\" would have none"));
  }
  {  // a group left without participants by randomization
    json j = example_json();
    j["participants"] = json::array({j["participants"][0], j["participants"][1]});
    const auto f = transfer_failure_of(j);
    EXPECT_THAT(f.field, ::testing::StartsWith("groups["));
    EXPECT_THAT(f.message, HasSubstr("has no participants after randomization: 2 participant(s) for 3 groups"));
  }
  {  // a post-test before training
    json j = example_json();
    std::swap(j["phases"][1], j["phases"][2]);
    const auto f = transfer_failure_of(j);
    EXPECT_EQ(f.field, "phases[2].phase");
    EXPECT_THAT(f.message, HasSubstr("is \"training\", but comes after \"post_test\": a post_test tests what training "
                                     "taught, so it must come after training"));
  }
  {  // a retention delay no longer than the training: 5 sittings 20 h apart span 80 h
    json j = example_json();
    j["phases"][3]["min_gap_h"] = 80;
    const auto f = transfer_failure_of(j);
    EXPECT_EQ(f.field, "phases[3].min_gap_h");
    EXPECT_THAT(f.message, HasSubstr("(the retention delay) is 80 h, but must exceed the training span, 80 h"));
    j["phases"][3]["min_gap_h"] = 80.5;
    EXPECT_EQ(transfer_failure_of(j).field, "(no error)");
  }
  {  // a stratification attribute that a participant lacks
    json j = example_json();
    j["participants"][4] = "T05";
    const auto f = transfer_failure_of(j);
    EXPECT_EQ(f.field, "participants[4].attributes.experience");
    EXPECT_THAT(f.message, HasSubstr("is missing for participant \"T05\", but stratify_by names \"experience\""));
  }
  {  // a within-participant field next to groups, and a training phase with a setting
    json j = example_json();
    j["design"] = {{"type", "complete"}};
    EXPECT_EQ(transfer_failure_of(j).field, "design");
    j = example_json();
    j["phases"][1]["setting"] = "High Fidelity";
    EXPECT_EQ(transfer_failure_of(j).field, "phases[1].setting");
  }
}

TEST(TransferDesignTest, ASittingBeforeItsDueDateIsRefusedUnlessOverridden) {
  const Protocol p = load_protocol_file(example_path());
  const std::vector<Sitting> sittings = group_sittings(p, 0);  // trained on High Fidelity
  ASSERT_EQ(sittings.size(), 8u);
  // The first sitting is due at once.
  EXPECT_EQ(check_sitting_start("T01", sittings, next_sitting_due(sittings, 0, std::nullopt), 0.0, false),
            SittingStart::kDue);
  // The pre-test ended at 2026-11-28T10:00:00Z; the first training sitting
  // is due 20 h later.
  const double pre_end_unix_s = 1795860000.0;
  const SittingDue due = next_sitting_due(sittings, 1, pre_end_unix_s);
  ASSERT_TRUE(due.due_unix_s.has_value());
  EXPECT_EQ(utc_text(*due.due_unix_s), "2026-11-29T06:00:00Z");
  const double an_hour_early_unix_s = *due.due_unix_s - 3600.0;
  try {
    check_sitting_start("T01", sittings, due, an_hour_early_unix_s, false);
    ADD_FAILURE() << "an early sitting was allowed";
  } catch (const SittingTooEarly& e) {
    EXPECT_THAT(e.what(), HasSubstr("participant T01's next sitting (training session 1) is not due before "
                                    "2026-11-29T06:00:00Z (1 h from now; the protocol's minimum gap is 20 h)"));
    EXPECT_THAT(e.what(), HasSubstr("--override-due-date"));
  }
  EXPECT_EQ(check_sitting_start("T01", sittings, due, an_hour_early_unix_s, true), SittingStart::kOverridden);
  EXPECT_EQ(check_sitting_start("T01", sittings, due, *due.due_unix_s, false), SittingStart::kDue);
  // Retention: 672 h after the post-test.
  const SittingDue retention = next_sitting_due(sittings, 7, pre_end_unix_s);
  EXPECT_EQ(sittings[retention.next].phase, PhaseKind::kRetention);
  EXPECT_EQ(*retention.due_unix_s, pre_end_unix_s + 672 * 3600.0);
  // The control group does only the tests.
  EXPECT_EQ(group_sittings(p, 2).size(), 3u);
}

}  // namespace
}  // namespace hapticlab::protocols
