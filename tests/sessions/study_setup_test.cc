#include "sessions/study_setup.h"

#include <fstream>
#include <set>
#include <tuple>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "sessions/study_progress.h"
#include "tests/sessions/session_fixture.h"

namespace hapticlab::sessions {
namespace {

using testing::SessionFixture;

TEST_F(SessionFixture, StoresTheWholeScheduleBeforeAnyTrialRuns) {
  db::StudyDb db(db_path_);
  const auto studies = db.studies();
  ASSERT_EQ(studies.size(), 1u);
  EXPECT_EQ(studies[0].seed, 11u);
  // 2 participants x 2 settings x 2 repetitions, all planned.
  const auto trials = db.trials(studies[0].id);
  ASSERT_EQ(trials.size(), 8u);
  std::set<std::tuple<std::string, std::string, int>> slots;
  for (const auto& t : trials) {
    EXPECT_EQ(t.status, db::TrialStatus::kPlanned);
    EXPECT_EQ(t.task, "dissection");
    slots.emplace(t.participant_code, t.setting_name, t.repetition);
  }
  EXPECT_EQ(slots.size(), 8u);
  // Full parameters, not just names: the stored JSON parses back.
  EXPECT_EQ(db.setting(trials[0].setting_id).name, trials[0].setting_name);
}

TEST_F(SessionFixture, RefusesASecondStudyInTheSameFile) {
  db::StudyDb db(db_path_);
  EXPECT_THROW(
      {
        try {
          create_study(db, protocol_, "test");
        } catch (const std::runtime_error& e) {
          EXPECT_NE(std::string(e.what()).find("already holds a study"), std::string::npos) << e.what();
          throw;
        }
      },
      std::runtime_error);
}

TEST_F(SessionFixture, ABadProtocolStoresNothing) {
  const auto bad = dir_ / "bad.json";
  std::ofstream(bad) << R"({"study": "x", "tasks": ["dissection"], "repetitions": {"dissection": 0},
    "settings": [], "participants": ["A"], "design": {"type": "complete"}, "seed": 1})";
  const auto path = dir_ / "other.db";
  db::StudyDb db(path);
  EXPECT_ANY_THROW(create_study(db, bad, "test"));
  EXPECT_TRUE(db.studies().empty());
  EXPECT_TRUE(db.trials().empty());
}

TEST_F(SessionFixture, ProgressCountsScheduledTrialsOncePerSlot) {
  db::StudyDb db(db_path_);
  const StudyProgress progress = study_progress(db);
  ASSERT_EQ(progress.participants.size(), 2u);
  for (const auto& p : progress.participants) {
    EXPECT_EQ(p.scheduled, 4);
    EXPECT_EQ(p.planned, 4);
    EXPECT_EQ(p.complete, 0);
  }
  const std::string text = format_study_progress(progress, true);
  EXPECT_NE(text.find("A1"), std::string::npos);
  EXPECT_NE(text.find("No Force Feedback"), std::string::npos);  // operator view names settings
  const auto json = study_progress_json(progress);
  EXPECT_EQ(json.dump().find("\"A1\"") != std::string::npos, true);
}

}  // namespace
}  // namespace hapticlab::sessions
