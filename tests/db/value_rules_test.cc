// value_rules.h is the schema's CHECK constraints written a second time, as
// data, for the check that finds a value breaking one in a file read
// read-only (where SQLite's integrity_check does not look at CHECKs). It
// must not drift from schema.cc: every CHECK of the tables the migrations
// make is in it; and a file edited around them is found, naming the row.
#include "db/value_rules.h"

#include <set>
#include <string>
#include <utility>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "db/structure_check.h"
#include "db/study_db.h"
#include "db_test_util.h"

namespace hapticlab::db {
namespace {

// Every "CHECK (...)" of every table's CREATE statement, with its table.
std::set<std::pair<std::string, std::string>> checks_in_file(Database& db) {
  std::set<std::pair<std::string, std::string>> out;
  Statement s = db.prepare("SELECT name, sql FROM sqlite_schema WHERE type = 'table' AND name NOT LIKE 'sqlite_%'");
  while (s.step()) {
    const std::string table = s.column_text(0), sql = s.column_text(1);
    for (std::size_t at = sql.find("CHECK"); at != std::string::npos; at = sql.find("CHECK", at + 1)) {
      std::size_t open = sql.find('(', at), depth = 0, i = open;
      for (; i < sql.size(); ++i) {
        depth += sql[i] == '(';
        depth -= sql[i] == ')';
        if (depth == 0) break;
      }
      out.insert({table, sql.substr(open + 1, i - open - 1)});
    }
  }
  return out;
}

TEST(ValueRules, AreEveryCheckOfTheSchema) {
  StudyDb db(":memory:");
  std::set<std::pair<std::string, std::string>> listed;
  for (const ValueRule& r : schema_value_rules()) {
    listed.insert({r.table, r.condition});
    EXPECT_THAT(std::string(r.condition), ::testing::HasSubstr(r.column)) << r.table;
  }
  EXPECT_EQ(listed, checks_in_file(db.connection()));
}

TEST(ValueRules, AValueEditedAroundACheckIsFoundNamingItsRow) {
  StudyDb db(":memory:");
  const std::int64_t trial = testing::make_trial(db);
  db.add_event({trial, 0.5, "contact_start", 0, 0, ""});
  EXPECT_TRUE(check_value_types(db.connection()).empty());
  db.connection().exec(
      "PRAGMA ignore_check_constraints = ON; UPDATE trial SET status = 'done'; UPDATE event SET instrument = 5; "
      "UPDATE session SET clock = 'bogus'; PRAGMA ignore_check_constraints = OFF");
  std::vector<std::string> found;
  for (const Finding& f : check_value_types(db.connection())) found.push_back(f.message);
  EXPECT_THAT(found, ::testing::UnorderedElementsAre(
                         "session row 1: clock is 'bogus', which breaks CHECK (clock IN ('virtual', 'wall'))",
                         "trial 1: status is 'done', which breaks CHECK (status IN ('planned', 'running', "
                         "'complete', 'aborted'))",
                         "event row 1 of trial 1: instrument is 5, which breaks CHECK (instrument IN (-1, 0, 1))"));
}

}  // namespace
}  // namespace hapticlab::db
