// schema_shape.h is the schema written a second time, as data, for the
// checks that refuse a file whose tables are not the schema's. It must not
// drift from schema.cc: every table the migrations make is in it, with the
// columns, declared types and NOT NULL that PRAGMA table_info reports, and
// the version that made it; and the checks built on it find a view, a
// table of another shape and a value of the wrong type, naming them.
#include "db/schema_shape.h"

#include <algorithm>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "db/schema.h"
#include "db/sqlite_handle.h"
#include "db/structure_check.h"
#include "db_test_util.h"

namespace hapticlab::db {
namespace {

using ::testing::HasSubstr;

// The tables a file of schema `version` has, built by replaying the migrations.
std::vector<std::string> tables_at(Database& db) {
  std::vector<std::string> out;
  Statement s = db.prepare("SELECT name FROM sqlite_schema WHERE type = 'table' AND name NOT LIKE 'sqlite_%' ORDER BY name");
  while (s.step()) out.push_back(s.column_text(0));
  return out;
}

std::vector<std::string> columns_in_file(Database& db, const std::string& table) {
  std::vector<std::string> out;
  Statement s = db.prepare("SELECT name, type, \"notnull\" FROM pragma_table_info(?1) ORDER BY cid");
  s.bind(1, table);
  while (s.step()) out.push_back(s.column_text(0) + " " + s.column_text(1) + (s.column_int64(2) ? " NOT NULL" : ""));
  return out;
}

std::vector<std::string> columns_in_shape(const TableShape& table) {
  std::vector<std::string> out;
  for (const ColumnShape& c : table.columns) out.push_back(std::string(c.name) + " " + c.type + (c.not_null ? " NOT NULL" : ""));
  return out;
}

TEST(SchemaShape, IsWhatReplayingTheMigrationsMakesAtEveryVersion) {
  testing::TempDir dir;
  Database db(dir.file("replayed.db"));
  for (const Migration& m : migrations()) {
    db.exec(m.sql);
    // The tables made by now are exactly those of the shape with since_version <= this one.
    std::vector<std::string> expected;
    for (const TableShape& t : schema_tables())
      if (t.since_version <= m.to_version) expected.push_back(t.name);
    std::sort(expected.begin(), expected.end());
    EXPECT_EQ(tables_at(db), expected) << "after the migration to version " << m.to_version;
  }
  for (const TableShape& t : schema_tables()) {
    EXPECT_EQ(columns_in_file(db, t.name), columns_in_shape(t)) << "table " << t.name;
    EXPECT_EQ(find_schema_table(t.name), &t);
  }
  EXPECT_EQ(find_schema_table("EVENT"), find_schema_table("event"));  // SQLite's names ignore ASCII case
  EXPECT_EQ(find_schema_table("events"), nullptr);
  EXPECT_TRUE(check_tables(db, kSchemaVersion).empty());
}

TEST(SchemaShape, AViewAnotherShapeAndAMistypedValueAreNamed) {
  testing::TempDir dir;
  Database db(dir.file("shapes.db"));
  for (const Migration& m : migrations()) db.exec(m.sql);
  db.exec(R"sql(
    PRAGMA foreign_keys = OFF;
    INSERT INTO study VALUES (1, 's', '{}', printf('%064d', 0), '5', '0.3.0', '2024-01-01T00:00:00.000Z');
    INSERT INTO participant VALUES (1, 1, 'P01');
    INSERT INTO setting VALUES (1, 1, 'No FFB', '{}', printf('%064d', 0));
    INSERT INTO session (id, participant_id, started_unix_s, ended_unix_s, device, clock, status)
      VALUES (1, 1, 0.0, 9.0, 'sim', 'virtual', 'closed');
    INSERT INTO trial VALUES (1, 1, 'clip', 1, 1, 1, 1, 'complete', 1, 1.0, 2.0, NULL);
    INSERT INTO trial VALUES (2, 1, 'clip', 9, 2, 1, 2, 'planned', NULL, NULL, NULL, NULL);
    INSERT INTO event VALUES (1, 1, 'nan', 'contact_end', 0, 0, NULL);
    INSERT INTO event VALUES (2, 1, 0.5, 'contact_end', 0, 0, NULL);
  )sql");

  const std::vector<Finding> types = check_value_types(db);
  ASSERT_EQ(types.size(), 1u);
  EXPECT_EQ(types[0].check, "type");
  EXPECT_EQ(types[0].table, "event");
  EXPECT_EQ(types[0].row, 1);
  EXPECT_EQ(types[0].trial_id, 1);
  EXPECT_EQ(types[0].message, "event row 1 of trial 1: t_s is text 'nan', expected a REAL");

  const std::vector<Finding> references = check_foreign_keys(db);
  ASSERT_EQ(references.size(), 1u);
  EXPECT_EQ(references[0].check, "foreign_key");
  EXPECT_EQ(references[0].trial_id, 2);
  EXPECT_EQ(references[0].message, "trial 2: setting_id 9 refers to no setting row");

  db.exec("DROP TABLE loop_timing; CREATE TABLE loop_timing (trial_id INTEGER PRIMARY KEY, count TEXT);"
          "DROP TABLE event; CREATE VIEW event AS SELECT 1 AS id;");
  const std::vector<Finding> shapes = check_tables(db, kSchemaVersion);
  ASSERT_EQ(shapes.size(), 2u);
  EXPECT_EQ(shapes[0].table, "event");
  EXPECT_THAT(shapes[0].message, HasSubstr("table event is a view, not a table"));
  EXPECT_EQ(shapes[1].table, "loop_timing");
  EXPECT_THAT(shapes[1].message,
              HasSubstr("table loop_timing has columns (trial_id INTEGER, count TEXT); expected (trial_id INTEGER, "
                        "count INTEGER, p50_period_s REAL"));
  // At an older version a view is refused too (before a migration reads it);
  // other columns are the migrations' business there.
  const std::vector<Finding> older = check_tables(db, 6);
  ASSERT_EQ(older.size(), 1u);
  EXPECT_EQ(older[0].table, "event");
}

}  // namespace
}  // namespace hapticlab::db
