#include "db/sqlite_handle.h"

#include <sqlite3.h>

#include <utility>

namespace hapticlab::db {
namespace {

// Long SQL is cut in messages: the start says which statement it was.
std::string quote_sql(std::string_view sql) {
  constexpr std::size_t kMax = 120;
  std::string s(sql.substr(0, kMax));
  for (char& c : s)
    if (c == '\n' || c == '\t') c = ' ';
  if (sql.size() > kMax) s += "...";
  return "\"" + s + "\"";
}

// A waiting writer retries this long before SQLITE_BUSY reaches the caller.
constexpr int kBusyTimeout_ms = 5000;

}  // namespace

Database::Database(const std::filesystem::path& path, Mode mode) : path_(path.string()) {
  int flags = SQLITE_OPEN_NOMUTEX;  // one thread per connection (see header)
  switch (mode) {
    case Mode::kReadWriteCreate: flags |= SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE; break;
    case Mode::kReadWrite: flags |= SQLITE_OPEN_READWRITE; break;
    case Mode::kReadOnly: flags |= SQLITE_OPEN_READONLY; break;
  }
  const int rc = sqlite3_open_v2(path_.c_str(), &db_, flags, nullptr);
  if (rc != SQLITE_OK) {
    // The handle exists (for its message) even when opening failed.
    const std::string message = db_ != nullptr ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
    sqlite3_close(db_);
    db_ = nullptr;
    throw DbError(path_ + ": open: " + message, rc);
  }
  sqlite3_extended_result_codes(db_, 1);
  sqlite3_busy_timeout(db_, kBusyTimeout_ms);
  exec("PRAGMA foreign_keys = ON");
}

bool DbError::is_damage() const noexcept {
  const int primary = sqlite_code_ & 0xff;
  return primary == SQLITE_CORRUPT || primary == SQLITE_NOTADB;
}

std::string unreadable_reason(const std::string& path, const DbError& error) {
  std::string reason = path + ": cannot be read here (" + error.what() + ")";
  if ((error.sqlite_code() & 0xff) == SQLITE_CANTOPEN)
    reason += "; a study file is in SQLite's WAL mode, which needs " + path +
              "-shm beside it: on a read-only file system or folder, copy the file (with its -wal, if there is "
              "one) to a writable folder";
  return reason + ". Nothing here says the file is damaged";
}

bool DbError::is_busy() const noexcept {
  const int primary = sqlite_code_ & 0xff;
  return primary == SQLITE_BUSY || primary == SQLITE_LOCKED;
}

void Database::set_busy_timeout(std::chrono::milliseconds timeout) {
  sqlite3_busy_timeout(db_, static_cast<int>(timeout.count()));
}

Database::~Database() {
  // sqlite3_close_v2 defers the close until stray statements are finalized;
  // with RAII statements there are none, but it never fails either way.
  sqlite3_close_v2(db_);
}

void Database::fail(std::string_view operation, int code) const {
  throw DbError(path_ + ": " + std::string(operation) + ": " + sqlite3_errmsg(db_), code);
}

void Database::exec(std::string_view sql) {
  const std::string text(sql);
  char* message = nullptr;
  const int rc = sqlite3_exec(db_, text.c_str(), nullptr, nullptr, &message);
  if (rc != SQLITE_OK) {
    const std::string why = message != nullptr ? message : sqlite3_errstr(rc);
    sqlite3_free(message);
    throw DbError(path_ + ": exec " + quote_sql(sql) + ": " + why, rc);
  }
}

Statement Database::prepare(std::string_view sql) { return Statement(*this, sql); }

std::int64_t Database::pragma_int(std::string_view pragma) {
  Statement s(*this, "PRAGMA " + std::string(pragma));
  if (!s.step()) throw DbError(path_ + ": PRAGMA " + std::string(pragma) + ": returned no row");
  return s.column_int64(0);
}

std::int64_t Database::last_insert_rowid() const noexcept { return sqlite3_last_insert_rowid(db_); }
int Database::changes() const noexcept { return sqlite3_changes(db_); }

Statement::Statement(Database& db, std::string_view sql) : db_(&db), sql_(sql) {
  const int rc = sqlite3_prepare_v2(db.raw(), sql_.data(), static_cast<int>(sql_.size()), &stmt_, nullptr);
  if (rc != SQLITE_OK) fail("prepare", rc);
}

Statement::~Statement() { sqlite3_finalize(stmt_); }

Statement::Statement(Statement&& other) noexcept
    : db_(other.db_), stmt_(std::exchange(other.stmt_, nullptr)), sql_(std::move(other.sql_)) {}

void Statement::fail(std::string_view operation, int code) const {
  throw DbError(db_->path() + ": " + std::string(operation) + " " + quote_sql(sql_) + ": " +
                    sqlite3_errmsg(db_->raw()),
                code);
}

Statement& Statement::bind(int index, std::int64_t value) {
  const int rc = sqlite3_bind_int64(stmt_, index, value);
  if (rc != SQLITE_OK) fail("bind", rc);
  return *this;
}

Statement& Statement::bind(int index, double value) {
  const int rc = sqlite3_bind_double(stmt_, index, value);
  if (rc != SQLITE_OK) fail("bind", rc);
  return *this;
}

Statement& Statement::bind(int index, std::string_view text) {
  const int rc = sqlite3_bind_text64(stmt_, index, text.data(), text.size(), SQLITE_TRANSIENT, SQLITE_UTF8);
  if (rc != SQLITE_OK) fail("bind", rc);
  return *this;
}

Statement& Statement::bind_blob(int index, std::span<const std::byte> data) {
  // A zero-length blob needs a non-null pointer or SQLite stores NULL.
  static const std::byte kEmpty{};
  const void* p = data.empty() ? &kEmpty : data.data();
  const int rc = sqlite3_bind_blob64(stmt_, index, p, data.size(), SQLITE_TRANSIENT);
  if (rc != SQLITE_OK) fail("bind", rc);
  return *this;
}

Statement& Statement::bind_null(int index) {
  const int rc = sqlite3_bind_null(stmt_, index);
  if (rc != SQLITE_OK) fail("bind", rc);
  return *this;
}

bool Statement::step() {
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  // Reset so the statement is usable again after the caller handles this.
  sqlite3_reset(stmt_);
  fail("step", rc);
}

void Statement::run() {
  if (step()) {
    sqlite3_reset(stmt_);
    throw DbError(db_->path() + ": run " + quote_sql(sql_) + ": returned a row, expected none");
  }
  sqlite3_reset(stmt_);
}

void Statement::reset() noexcept { sqlite3_reset(stmt_); }

bool Statement::is_null(int column) const noexcept {
  return sqlite3_column_type(stmt_, column) == SQLITE_NULL;
}
std::int64_t Statement::column_int64(int column) const noexcept { return sqlite3_column_int64(stmt_, column); }
double Statement::column_double(int column) const noexcept { return sqlite3_column_double(stmt_, column); }

std::string Statement::column_text(int column) const {
  const unsigned char* p = sqlite3_column_text(stmt_, column);
  const int n = sqlite3_column_bytes(stmt_, column);
  return p == nullptr ? std::string() : std::string(reinterpret_cast<const char*>(p), static_cast<std::size_t>(n));
}

std::span<const std::byte> Statement::column_blob(int column) const noexcept {
  const void* p = sqlite3_column_blob(stmt_, column);
  const int n = sqlite3_column_bytes(stmt_, column);
  if (p == nullptr) return {};
  return {static_cast<const std::byte*>(p), static_cast<std::size_t>(n)};
}

Transaction::Transaction(Database& db) : db_(db) { db_.exec("BEGIN IMMEDIATE"); }

Transaction::~Transaction() {
  if (done_) return;
  // Best effort; if the connection is broken SQLite has rolled back already.
  sqlite3_exec(db_.raw(), "ROLLBACK", nullptr, nullptr, nullptr);
}

void Transaction::commit() {
  db_.exec("COMMIT");
  done_ = true;
}

}  // namespace hapticlab::db
