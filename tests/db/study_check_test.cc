// check_study_file runs its checks in an order that keeps each one safe:
// the chunks only when the tables are the schema's and the file is at the
// current version, and otherwise it says why they were not checked.
#include "db/study_check.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/common/sha256.h"
#include "db/schema.h"
#include "db/study_db.h"
#include "db_test_util.h"

namespace hapticlab::db {
namespace {

using ::testing::HasSubstr;

TEST(StudyCheck, ASoundFileHasNoFindingsAndItsChunksChecked) {
  testing::TempDir dir;
  const auto path = dir.file("sound.db");
  { StudyDb made(path); }
  Database conn(path, Database::Mode::kReadOnly);
  const StudyFileCheck c = check_study_file(conn);
  EXPECT_TRUE(c.findings.empty());
  EXPECT_EQ(c.not_checked, "");
  EXPECT_FALSE(c.damaged());
}

// A trial whose session is another participant's: every reference exists,
// so foreign_key_check passes; every reader took it as the trial's.
TEST(StudyCheck, ATrialInAnotherParticipantsSessionIsAFinding) {
  testing::TempDir dir;
  const auto path = dir.file("other.db");
  {
    StudyDb made(path);
    const std::int64_t trial = testing::make_trial(made);  // P01's, in P01's session 1
    const std::int64_t p02 = made.add_participant(made.studies().front().id, "P02");
    made.begin_session(p02, "sim", "virtual", 1000.0);  // session 2
    made.connection().exec("UPDATE trial SET session_id = 2 WHERE id = " + std::to_string(trial));
  }
  Database conn(path, Database::Mode::kReadOnly);
  const StudyFileCheck c = check_study_file(conn);
  ASSERT_EQ(c.findings.size(), 1u);
  EXPECT_EQ(c.findings[0].message, "trial 1: session_id 2 is participant 'P02''s session, but the trial is "
                                   "participant 'P01''s");
  // Every reader refuses the file at open, naming it.
  EXPECT_THAT([&] { StudyDb(path, OpenOptions{.read_only = true}); },
              ::testing::ThrowsMessage<DbError>(HasSubstr("session_id 2 is participant 'P02''s session")));
}

// A trial of a task its protocol does not name was analysed as a task of
// its own, and left its own task's comparisons.
TEST(StudyCheck, ATaskTheProtocolDoesNotNameIsAFinding) {
  testing::TempDir dir;
  const auto path = dir.file("task.db");
  {
    StudyDb made(path);
    testing::make_trial(made);  // task "dissection"
    const std::string protocol = R"({"study": "test", "tasks": ["clip", "dissection"]})";
    made.connection()
        .prepare("UPDATE study SET protocol_json = ?1, protocol_sha256 = ?2")
        .bind(1, protocol)
        .bind(2, sha256_hex(protocol))
        .run();
  }
  {
    Database conn(path, Database::Mode::kReadOnly);
    EXPECT_TRUE(check_study_file(conn).findings.empty());
  }
  Database(path).exec("UPDATE trial SET task = 'foo'");
  Database conn(path, Database::Mode::kReadOnly);
  const StudyFileCheck c = check_study_file(conn);
  ASSERT_EQ(c.findings.size(), 1u);
  EXPECT_EQ(c.findings[0].message, "trial 1: task 'foo' is not one of its study's protocol's tasks (clip, dissection)");
}

// A setting's parameters edited with an SQLite shell were what every later
// session configured its engine with, and nothing said so; an edited
// protocol text likewise. Each is a finding of `study check`, and every
// reader (StudyDb) refuses the row, naming it.
TEST(StudyCheck, AnEditedSettingOrProtocolIsAFindingAndReadersRefuseIt) {
  testing::TempDir dir;
  const auto path = dir.file("edited.db");
  std::int64_t setting = 0;
  {
    StudyDb made(path);
    setting = made.trial(testing::make_trial(made, false, "High Fidelity")).setting_id;
    EXPECT_EQ(made.setting_json(setting), "{}");
    made.connection().exec(R"(UPDATE setting SET parameters_json = '{"translation": {"friction": {}}}')");
  }
  {
    Database conn(path, Database::Mode::kReadOnly);
    const StudyFileCheck c = check_study_file(conn);
    ASSERT_EQ(c.findings.size(), 1u);
    EXPECT_EQ(c.findings[0].check, "edited");
    EXPECT_EQ(c.findings[0].table, "setting");
    EXPECT_EQ(c.findings[0].row, setting);
    EXPECT_THAT(c.findings[0].message,
                HasSubstr("setting 'High Fidelity' (id " + std::to_string(setting) +
                          "): its parameters_json does not match the SHA-256 stored with it "
                          "(stored " + sha256_hex("{}").substr(0, 12) + "..."));
    EXPECT_TRUE(c.damaged());
  }
  // Every reader refuses the file at open; one that skips the row checks
  // (or had the file open before the edit: a session runs for hours)
  // refuses the setting when it reads it.
  EXPECT_THAT([&] { StudyDb(path, OpenOptions{.read_only = true}); },
              ::testing::ThrowsMessage<DbError>(HasSubstr("setting 'High Fidelity' (id " + std::to_string(setting) +
                                                          "): its parameters_json does not match")));
  {
    StudyDb db(path, OpenOptions{.integrity = OpenOptions::Integrity::kSkip, .read_only = true});
    EXPECT_THAT([&] { db.setting_json(setting); },
                ::testing::ThrowsMessage<DbError>(HasSubstr(path.string() + ": setting 'High Fidelity'")));
    EXPECT_THAT([&] { db.setting(setting); }, ::testing::ThrowsMessage<DbError>(HasSubstr("refused")));
  }
  // Put back, the setting reads again; then the protocol is edited.
  Database(path).exec("UPDATE setting SET parameters_json = '{}'");
  Database(path).exec(R"(UPDATE study SET protocol_json = '{"study": "edited"}')");
  {
    Database conn(path, Database::Mode::kReadOnly);
    const StudyFileCheck c = check_study_file(conn);
    ASSERT_EQ(c.findings.size(), 1u);
    EXPECT_EQ(c.findings[0].check, "edited");
    EXPECT_EQ(c.findings[0].table, "study");
    EXPECT_THAT(c.findings[0].message, HasSubstr("study 1: its protocol_json does not match the SHA-256"));
  }
  {
    StudyDb db(path, OpenOptions{.integrity = OpenOptions::Integrity::kSkip, .read_only = true});
    EXPECT_EQ(db.setting_json(setting), "{}");
    EXPECT_THAT([&] { db.studies(); },
                ::testing::ThrowsMessage<DbError>(HasSubstr("study 1: its protocol_json does not match")));
  }
  // A setting without a digest (a program older than schema 11 wrote it
  // into the migrated file) is said as such, not as an edit.
  Database(path).exec(R"(UPDATE study SET protocol_json = '{"study": "test"}'; UPDATE setting SET )"
                      R"(parameters_sha256 = '')");
  Database conn(path, Database::Mode::kReadOnly);
  const StudyFileCheck c = check_study_file(conn);
  ASSERT_EQ(c.findings.size(), 1u);
  EXPECT_THAT(c.findings[0].message, HasSubstr("): no SHA-256 is stored with its parameters_json: it was written by a "
                                               "HapticLab older than schema version 11"));
}

// A trial left 'running' in a session that has ended was counted as not
// run by the analysis, its samples and all.
TEST(StudyCheck, ATrialRunningInASessionThatEndedIsAFinding) {
  testing::TempDir dir;
  const auto path = dir.file("stale.db");
  {
    StudyDb made(path);
    testing::make_trial(made);  // running, in session 1 (open)
    made.connection().exec("UPDATE session SET status = 'closed'");
  }
  Database conn(path, Database::Mode::kReadOnly);
  const StudyFileCheck c = check_study_file(conn);
  ASSERT_EQ(c.findings.size(), 1u);
  EXPECT_EQ(c.findings[0].message, "trial 1: status is 'running', but its session 1 is closed (a session ends after "
                                   "its trials)");
}

// A trial edited back to 'planned' kept its samples, which export and
// analyze then left out without a word; a trial edited to 'complete' that
// never ran (no session, no times) was analysed as "no samples logged".
TEST(StudyCheck, AStatusAtOddsWithWhatTheTrialHoldsIsAFinding) {
  testing::TempDir dir;
  const auto path = dir.file("status.db");
  {
    StudyDb made(path);
    const std::int64_t ran = testing::make_trial(made);  // running, in session 1
    std::vector<StoredSample> samples;
    for (std::uint64_t t = 0; t < 10; ++t) {
      const LoopSample s = testing::make_sample(t);
      samples.push_back({s.tick, s.t_s, s.dt_s, s.device_status, s.instrument[0]});
    }
    made.insert_chunk(ran, 0, samples);
    made.end_trial(ran, TrialStatus::kComplete);
    const TrialRow row = made.trial(ran);
    const std::int64_t never_ran = made.add_trial({row.participant_id, "dissection", row.setting_id, 3, 3, 6});
    made.connection().exec("UPDATE trial SET status = 'planned' WHERE id = " + std::to_string(ran));
    made.connection().exec("UPDATE trial SET status = 'complete' WHERE id = " + std::to_string(never_ran));
  }
  Database conn(path, Database::Mode::kReadOnly);
  const StudyFileCheck c = check_study_file(conn);
  ASSERT_EQ(c.findings.size(), 2u);
  EXPECT_THAT(c.findings[0].message,
              ::testing::AllOf(::testing::StartsWith("trial 1: status is 'planned', but it has session_id 1, "
                                                     "started_unix_s "),
                               HasSubstr(", ended_unix_s "),
                               ::testing::EndsWith(", 1 sample chunk(s) (a planned trial has not run: what it holds "
                                                   "is read by no export or analysis)")));
  EXPECT_EQ(c.findings[1].message, "trial 2: status is 'complete', but session_id, started_unix_s, ended_unix_s are "
                                   "NULL (a trial gets its session and start time when it starts, and a complete one "
                                   "its end time)");
  EXPECT_EQ(c.findings[1].trial_id, 2);
  // Every reader refuses the file at open, naming them.
  EXPECT_THAT([&] { StudyDb(path, OpenOptions{.read_only = true}); },
              ::testing::ThrowsMessage<DbError>(HasSubstr("status is 'planned', but it has session_id 1")));
}

TEST(StudyCheck, AViewInATablesPlaceIsAFindingAndNoQueryReadsTheChunks) {
  testing::TempDir dir;
  const auto path = dir.file("view.db");
  { StudyDb made(path); }
  { Database(path).exec("DROP TABLE event; CREATE VIEW event AS SELECT 1 AS id;"); }
  Database conn(path, Database::Mode::kReadOnly);
  const StudyFileCheck c = check_study_file(conn);
  ASSERT_EQ(c.findings.size(), 1u);
  EXPECT_EQ(c.findings[0].check, "schema");
  EXPECT_EQ(c.findings[0].table, "event");
  EXPECT_EQ(c.structure, 1u);
  EXPECT_EQ(c.integrity, 0u);
  EXPECT_THAT(c.not_checked, HasSubstr("the tables are not what the schema says"));
  EXPECT_EQ(c.chunks.chunks, 0u);
  EXPECT_TRUE(c.damaged());
}

TEST(StudyCheck, AnOlderSchemaIsNotCheckedAndSaysHowToMigrateIt) {
  testing::TempDir dir;
  const auto path = dir.file("v8.db");
  {
    Database db(path);
    for (const Migration& m : migrations().first(8)) db.exec(m.sql);
    db.exec("PRAGMA user_version = 8; PRAGMA application_id = 1212956994;");
  }
  Database conn(path, Database::Mode::kReadOnly);
  const StudyFileCheck c = check_study_file(conn);
  EXPECT_TRUE(c.findings.empty());
  EXPECT_THAT(c.not_checked, HasSubstr("schema version 8 predates this HapticLab's checks"));
  EXPECT_THAT(c.not_checked, HasSubstr("migrates it, then check again"));
  EXPECT_TRUE(c.damaged());
}

}  // namespace
}  // namespace hapticlab::db
