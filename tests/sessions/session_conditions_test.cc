// A session stores the loop's rate and the model of the simulated
// participant that held the device; a study whose sessions differ in
// either says so at the session's end, in `study show` and in analyze
// (analysis/study/session_conditions.h), never silently.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/study/session_conditions.h"
#include "core/sim/population.h"
#include "sessions/session_runner.h"
#include "sessions/study_progress.h"
#include "tests/sessions/session_fixture.h"
#include "tests/testing/sqlite_edit.h"

namespace hapticlab::sessions {
namespace {

using ::testing::HasSubstr;
using testing::SessionFixture;

db::SessionRow session_row(const std::filesystem::path& path, std::int64_t id) {
  db::OpenOptions open;
  open.recover = false;
  return db::StudyDb(path, open).session(id);
}

TEST_F(SessionFixture, ASessionStoresItsRateAndModelAndAStudyThatMixesThemSaysSo) {
  SessionOptions o = testing::options_for("A1");
  o.max_trials = 1;
  const SessionResult first = run_session(db_path_, o);
  const db::SessionRow row = session_row(db_path_, first.session_id);
  ASSERT_TRUE(row.rate_Hz.has_value());
  EXPECT_EQ(*row.rate_Hz, 1000.0);
  EXPECT_EQ(row.participant_model, describe_participant_model(o.population));
  EXPECT_THAT(row.participant_model, HasSubstr("visual_gain_mean=0.65 visual_gain_sd=0.1 "));
  EXPECT_TRUE(first.condition_warnings.empty());

  // The same study resumed at another rate: said at the session's end.
  o.rate_Hz = 500.0;
  const SessionResult second = run_session(db_path_, o);
  ASSERT_EQ(second.condition_warnings.size(), 1u);
  EXPECT_THAT(second.condition_warnings[0],
              HasSubstr("differ in the haptic loop's rate: 1000 Hz (session 1); 500 Hz (session 2); their trials are "
                        "not comparable"));

  // ... and from another population, at the first rate: both said.
  o.rate_Hz = 1000.0;
  o.population.visual_gain_mean = 0.5;
  const SessionResult third = run_session(db_path_, o);
  ASSERT_EQ(third.condition_warnings.size(), 2u);
  EXPECT_THAT(third.condition_warnings[0], HasSubstr("1000 Hz (sessions 1, 3); 500 Hz (session 2)"));
  EXPECT_THAT(third.condition_warnings[1], HasSubstr("differ in who held the device: simulated, participant model"));
  EXPECT_THAT(third.condition_warnings[1], HasSubstr("visual_gain_mean=0.5 "));
  EXPECT_THAT(third.condition_warnings[1], HasSubstr("(session 3)"));

  // study show says it too (and analyze reads the same, analysis/study/session_conditions.h).
  db::OpenOptions open;
  open.read_only = true;
  db::StudyDb db(db_path_, open);
  const std::string shown = format_study_progress(study_progress(db), false);
  EXPECT_THAT(shown, HasSubstr("sessions: loop rate mixed: 1000 Hz (sessions 1, 3); 500 Hz (session 2)"));
  EXPECT_THAT(shown, HasSubstr("warning: the study's sessions differ in who held the device"));
}

// A session in which no trial ran (stopped before its first) is not one
// whose trials could be mixed: it is left out.
TEST_F(SessionFixture, ASessionWithoutTrialsIsNotCountedAsACondition) {
  SessionOptions o = testing::options_for("A1");
  o.max_trials = 1;
  run_session(db_path_, o);
  o.rate_Hz = 500.0;
  o.max_trials = 0;
  EXPECT_TRUE(run_session(db_path_, o).condition_warnings.empty());
  db::OpenOptions open;
  open.recover = false;
  db::StudyDb db(db_path_, open);
  const analysis::SessionConditions c = analysis::read_session_conditions(db, db.studies().front().id);
  EXPECT_EQ(c.rate_text, "1000 Hz");
  EXPECT_THAT(c.participant_text, ::testing::StartsWith("simulated, participant model "));
}

// A session's recorded rate edited (500 Hz for a session whose trials'
// loops measured a 1 ms period) passed every check and the report printed
// 500 Hz. The rate is compared with what the trials measured.
TEST_F(SessionFixture, ARecordedRateTheTrialsDidNotRunAtIsAWarning) {
  SessionOptions o = testing::options_for("A1");
  o.max_trials = 2;
  run_session(db_path_, o);
  const auto conditions = [&] {
    db::OpenOptions open;
    open.recover = false;
    db::StudyDb db(db_path_, open);
    return analysis::read_session_conditions(db, db.studies().front().id);
  };
  EXPECT_TRUE(conditions().warnings.empty());
  hapticlab::testing::edit_with_sqlite(db_path_, "UPDATE session SET rate_Hz = 500");
  const analysis::SessionConditions c = conditions();
  ASSERT_EQ(c.warnings.size(), 1u);
  EXPECT_THAT(c.warnings[0], HasSubstr("session 1 is recorded at 500 Hz, but its complete trials' loops ran at "
                                       "1000 Hz (mean period 1 ms, the median over 2 trials)"));
}

}  // namespace
}  // namespace hapticlab::sessions
