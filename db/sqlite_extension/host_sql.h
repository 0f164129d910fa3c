#pragma once
// The host's SQLite connection as the extension uses it (hapticlab_sqlite.cc,
// study_checks.cc): statements finalized when dropped, and errors that
// travel to SQLite as the virtual table's message. Through <sqlite3ext.h>
// only: the host's API table, never libsqlite3.

#include <sqlite3ext.h>
SQLITE_EXTENSION_INIT3

#include <string>

namespace hapticlab::sqlite_ext {

// A prepared statement of the host connection, finalized when dropped.
class Stmt {
 public:
  Stmt() = default;
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;
  ~Stmt() { sqlite3_finalize(stmt_); }
  // Returns an error message, empty on success.
  std::string prepare(sqlite3* db, const char* sql) {
    finalize();
    if (sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr) != SQLITE_OK)
      return std::string(sqlite3_errmsg(db)) + " (in: " + sql + ")";
    return {};
  }
  sqlite3_stmt* get() const noexcept { return stmt_; }
  void finalize() noexcept {
    sqlite3_finalize(stmt_);
    stmt_ = nullptr;
  }

 private:
  sqlite3_stmt* stmt_ = nullptr;
};

// An error for SQLite: the message travels in the vtab's zErrMsg.
struct QueryError {
  std::string message;
};

// The file the connection reads ("main"), for messages; ":memory:" or
// "(temporary)" when it has none.
inline std::string file_name(sqlite3* db) {
  const char* name = sqlite3_db_filename(db, "main");
  return name == nullptr || *name == '\0' ? std::string("(temporary database)") : std::string(name);
}

// A statement of the host connection, prepared from `sql` or a QueryError.
inline void prepare(Stmt& s, sqlite3* db, const std::string& sql) {
  const std::string err = s.prepare(db, sql.c_str());
  if (!err.empty()) throw QueryError{"samples: " + file_name(db) + ": " + err};
}

// sqlite3_step, a QueryError for anything but a row or the end.
inline bool step(sqlite3* db, sqlite3_stmt* s) {
  const int rc = sqlite3_step(s);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  throw QueryError{"samples: " + file_name(db) + ": " + sqlite3_errmsg(db)};
}

inline std::string text(sqlite3_stmt* s, int c) {
  const auto* t = reinterpret_cast<const char*>(sqlite3_column_text(s, c));
  return t == nullptr ? std::string() : std::string(t);
}

}  // namespace hapticlab::sqlite_ext
