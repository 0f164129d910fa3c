#pragma once
// Runs SQL on a file as any SQLite client could, constraints and
// checksums being the file's own business: how the tests make damaged
// copies of study files and plan_power.db.
#include <sqlite3.h>

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

namespace hapticlab::testing {

inline void edit_with_sqlite(const std::filesystem::path& db, const std::string& sql) {
  sqlite3* c = nullptr;
  ASSERT_EQ(sqlite3_open(db.c_str(), &c), SQLITE_OK);
  char* error = nullptr;
  const int rc = sqlite3_exec(c, sql.c_str(), nullptr, nullptr, &error);
  const std::string message = error ? error : "";
  sqlite3_free(error);
  sqlite3_close(c);
  ASSERT_EQ(rc, SQLITE_OK) << sql << ": " << message;
}

}  // namespace hapticlab::testing
