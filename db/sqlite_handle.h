#pragma once
// RAII around the SQLite C API: a connection (Database), prepared
// statements (Statement) and transactions (Transaction).
//
// Every failure throws DbError whose message names the database file, the
// operation and, where there is one, the SQL, followed by SQLite's own
// message: "study.db: prepare \"INSERT INTO trial ...\": no such table: trial".
// Destructors never throw: a statement is finalized, an uncommitted
// transaction rolled back, a connection closed, and any error there is
// swallowed (there is nobody left to report it to).
//
// Threads: a Database and its statements belong to one thread at a time.
// Two threads that both write use two connections to the same file (WAL
// mode lets them, one writer at a time; the busy timeout makes the second
// wait instead of failing).

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>

struct sqlite3;
struct sqlite3_stmt;

namespace hapticlab::db {

class DbError;

// `error` of a check that could not read `path`, said as what it is: not
// damage. SQLITE_CANTOPEN gets the likeliest cause: a study file is in WAL
// mode, and SQLite must create PATH-shm beside it to read it, which a
// read-only file system or folder refuses.
std::string unreadable_reason(const std::string& path, const DbError& error);

class DbError : public std::runtime_error {
 public:
  DbError(const std::string& message, int sqlite_code = 0)
      : std::runtime_error(message), sqlite_code_(sqlite_code) {}
  // The SQLite result code (SQLITE_CORRUPT, SQLITE_BUSY, ...), 0 when the
  // error did not come from SQLite.
  int sqlite_code() const noexcept { return sqlite_code_; }
  // Another connection held the lock for longer than the busy timeout
  // (SQLITE_BUSY or SQLITE_LOCKED, any extended code): the same work may
  // succeed when tried again; nothing was written.
  bool is_busy() const noexcept;
  // The file's content is damaged (SQLITE_CORRUPT, SQLITE_NOTADB), as
  // opposed to a file that cannot be read here (a read-only folder, a
  // lock, an I/O error): only then may a message call it damaged.
  bool is_damage() const noexcept;

 private:
  int sqlite_code_;
};

class Statement;

class Database {
 public:
  enum class Mode { kReadWriteCreate, kReadWrite, kReadOnly };

  // Opens (or creates) the file. ":memory:" gives a private in-memory
  // database. Sets a busy timeout and turns foreign keys on.
  explicit Database(const std::filesystem::path& path, Mode mode = Mode::kReadWriteCreate);
  ~Database();
  // Not copyable; statements keep a reference to their connection.
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;

  // Runs one or more statements that return no rows we need.
  void exec(std::string_view sql);
  Statement prepare(std::string_view sql);

  // How long a statement waits for another connection's lock before it
  // fails with SQLITE_BUSY (5 s unless changed).
  void set_busy_timeout(std::chrono::milliseconds timeout);

  // PRAGMA that returns one integer (user_version, page_count, ...).
  std::int64_t pragma_int(std::string_view pragma);

  std::int64_t last_insert_rowid() const noexcept;
  int changes() const noexcept;
  const std::string& path() const noexcept { return path_; }
  sqlite3* raw() const noexcept { return db_; }

  // "<file>: <operation>: <sqlite message>" as a DbError, with the code.
  [[noreturn]] void fail(std::string_view operation, int code) const;

 private:
  sqlite3* db_ = nullptr;
  std::string path_;
};

class Statement {
 public:
  Statement(Database& db, std::string_view sql);
  ~Statement();
  Statement(Statement&& other) noexcept;
  Statement& operator=(Statement&&) = delete;
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  // Parameters are 1-based, as in SQLite. Text and blobs are copied.
  Statement& bind(int index, std::int64_t value);
  Statement& bind(int index, double value);
  Statement& bind(int index, std::string_view text);
  Statement& bind(int index, const char* text) { return bind(index, std::string_view(text)); }
  Statement& bind_blob(int index, std::span<const std::byte> data);
  Statement& bind_null(int index);

  // True when a row is ready, false when the statement is done.
  bool step();
  // step() that must finish without a row (INSERT, UPDATE, ...).
  void run();
  // Ready to step again; bindings are kept.
  void reset() noexcept;

  // Columns are 0-based, as in SQLite.
  bool is_null(int column) const noexcept;
  std::int64_t column_int64(int column) const noexcept;
  double column_double(int column) const noexcept;
  std::string column_text(int column) const;
  std::span<const std::byte> column_blob(int column) const noexcept;

  const std::string& sql() const noexcept { return sql_; }

 private:
  [[noreturn]] void fail(std::string_view operation, int code) const;

  Database* db_;
  sqlite3_stmt* stmt_ = nullptr;
  std::string sql_;
};

// BEGIN IMMEDIATE on construction (takes the write lock at once, so a busy
// database is noticed here and not halfway through), ROLLBACK in the
// destructor unless commit() was called.
class Transaction {
 public:
  explicit Transaction(Database& db);
  ~Transaction();
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  void commit();

 private:
  Database& db_;
  bool done_ = false;
};

}  // namespace hapticlab::db
