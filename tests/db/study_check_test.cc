// check_study_file runs its checks in an order that keeps each one safe:
// the chunks only when the tables are the schema's and the file is at the
// current version, and otherwise it says why they were not checked.
#include "db/study_check.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

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
