#include "db/sqlite_handle.h"

#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "db_test_util.h"

namespace hapticlab::db {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

std::string error_of(auto&& f) {
  try {
    f();
  } catch (const DbError& e) {
    return e.what();
  }
  return "no error";
}

TEST(SqliteHandle, ErrorsNameTheFileTheOperationAndTheSql) {
  testing::TempDir dir;
  const auto path = dir.file("named.db");
  Database db(path);
  db.exec("CREATE TABLE t (x INTEGER NOT NULL)");
  EXPECT_THAT(error_of([&] { db.prepare("SELECT nope FROM t"); }),
              AllOf(HasSubstr(path.string()), HasSubstr("prepare"), HasSubstr("SELECT nope FROM t"),
                    HasSubstr("no such column: nope")));
  EXPECT_THAT(error_of([&] { db.prepare("INSERT INTO t (x) VALUES (NULL)").run(); }),
              AllOf(HasSubstr(path.string()), HasSubstr("step"), HasSubstr("INSERT INTO t"),
                    HasSubstr("NOT NULL constraint failed: t.x")));
  EXPECT_THAT(error_of([&] { db.exec("DROP TABLE missing"); }),
              AllOf(HasSubstr(path.string()), HasSubstr("exec"), HasSubstr("DROP TABLE missing"),
                    HasSubstr("no such table: missing")));
}

TEST(SqliteHandle, OpeningAMissingFileReadOnlyNamesIt) {
  testing::TempDir dir;
  const auto path = dir.file("absent.db");
  EXPECT_THAT(error_of([&] { Database db(path, Database::Mode::kReadOnly); }),
              AllOf(HasSubstr(path.string()), HasSubstr("open")));
}

TEST(SqliteHandle, TransactionRollsBackUnlessCommitted) {
  Database db(":memory:");
  db.exec("CREATE TABLE t (x INTEGER)");
  try {
    Transaction tx(db);
    db.exec("INSERT INTO t VALUES (1)");
    throw std::runtime_error("something failed midway");
  } catch (const std::runtime_error&) {
  }
  {
    Transaction tx(db);
    db.exec("INSERT INTO t VALUES (2)");
    tx.commit();
  }
  Statement s = db.prepare("SELECT group_concat(x) FROM t");
  ASSERT_TRUE(s.step());
  EXPECT_EQ(s.column_text(0), "2");
}

TEST(SqliteHandle, BindsAndReadsEveryType) {
  Database db(":memory:");
  db.exec("CREATE TABLE t (i INTEGER, d REAL, s TEXT, b BLOB, n INTEGER)");
  const std::byte blob[3] = {std::byte{0}, std::byte{0xff}, std::byte{7}};
  db.prepare("INSERT INTO t VALUES (?1, ?2, ?3, ?4, ?5)")
      .bind(1, std::int64_t{-9'000'000'000})
      .bind(2, 0.1)
      .bind(3, "text, with \"quotes\"")
      .bind_blob(4, blob)
      .bind_null(5)
      .run();
  Statement s = db.prepare("SELECT i, d, s, b, n FROM t");
  ASSERT_TRUE(s.step());
  EXPECT_EQ(s.column_int64(0), -9'000'000'000);
  EXPECT_EQ(s.column_double(1), 0.1);
  EXPECT_EQ(s.column_text(2), "text, with \"quotes\"");
  ASSERT_EQ(s.column_blob(3).size(), 3u);
  EXPECT_EQ(s.column_blob(3)[1], std::byte{0xff});
  EXPECT_TRUE(s.is_null(4));
  EXPECT_FALSE(s.step());
}

}  // namespace
}  // namespace hapticlab::db
