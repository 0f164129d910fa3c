// hapticlab_sqlite: an SQLite loadable extension that makes the sample
// chunks of a study database queryable from any SQLite client (the sqlite3
// shell, Python's sqlite3, R's RSQLite):
//
//   SELECT * FROM samples(trial_id [, instrument]);
//
// `samples` is an eponymous table-valued function (a read-only virtual
// table). It reads `sample_chunk` rows of the connection it was loaded
// into, with SQL, and decodes them with db/sample_codec (compiled into this
// module), so every read verifies the chunk's CRC-32C first. Columns are
// those of `hapticlab export`'s samples CSV (db/export_csv.h) without the
// text keys: trial_id, instrument, tick, then the codec's channels in
// kChannelNames order. Usage and examples: db/README.md, "SQL access".
//
// This file talks to SQLite only through <sqlite3ext.h> (the host's API
// table), never by linking libsqlite3: the module must use the library of
// the process that loads it.

#include <sqlite3ext.h>
SQLITE_EXTENSION_INIT1

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <new>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "db/chunk_layout.h"
#include "db/sample_codec.h"
#include "db/schema_shape.h"

namespace {

using hapticlab::db::BadChunk;
using hapticlab::db::ChunkDecoder;
using hapticlab::db::ChunkError;
using hapticlab::db::ChunkRow;
using hapticlab::db::kChannelNames;
using hapticlab::db::kChunkChannels;
using hapticlab::db::StoredSample;
using hapticlab::db::TableShape;

// The schema this module reads: version 9 (db/schema.h); since version 7 its chunks
// checksums cover their trial and instrument. Older files are migrated by
// any HapticLab command that opens them read-write (`hapticlab analyze`).
constexpr int kSchemaVersion = 9;
constexpr std::int64_t kApplicationId = 0x484C4142;  // "HLAB"

// Columns: trial_id, instrument, tick, the channels, then the two hidden
// argument columns of samples(trial_id, instrument). The hidden ones mirror
// trial_id and instrument, so a constraint SQLite evaluates itself on them
// (a plan that did not use it) still means the same thing.
constexpr int kColTrial = 0, kColInstrument = 1, kColTick = 2, kColFirstChannel = 3;
constexpr int kColArgTrial = kColFirstChannel + static_cast<int>(kChunkChannels);
constexpr int kColArgInstrument = kColArgTrial + 1;

// Channel numbers in kChannelNames order (sample_codec.h): float64, then
// float32, then the three integers.
constexpr std::size_t kChDt = 0, kChT = 1, kChFirstFloat = 2, kChEngineStatus = 25, kChDeviceStatus = 26,
                      kChInContact = 27;

// idxNum bits: which arguments xFilter receives, in this order.
constexpr int kHasTrial = 1, kHasInstrument = 2, kTrialFromArgs = 4, kInstrumentFromArgs = 8;

std::string create_table_sql() {
  std::string sql = "CREATE TABLE x(trial_id INTEGER, instrument INTEGER, tick INTEGER";
  for (std::size_t c = 0; c < kChunkChannels; ++c)
    sql += std::string(", ") + kChannelNames[c] + (c < kChEngineStatus ? " REAL" : " INTEGER");
  return sql + ", arg_trial_id HIDDEN, arg_instrument HIDDEN)";
}

// The value of channel `c` of one stored sample; float32 channels come back
// as the double equal to the stored float.
double float_channel(const StoredSample& s, std::size_t c) {
  const auto& v = s.value;
  const std::size_t k = c - kChFirstFloat;
  if (k < 5) return v.raw_position[k];
  if (k < 8) return v.degraded_position[k - 5];
  if (k < 11) return v.tip_position_m[k - 8];
  if (k < 14) return v.tip_velocity_m_per_s[k - 11];
  if (k < 17) return v.ve_force_N[k - 14];
  if (k < 20) return v.displayed_force_N[k - 17];
  return v.joint_force[k - 20];
}

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
std::string file_name(sqlite3* db) {
  const char* name = sqlite3_db_filename(db, "main");
  return name == nullptr || *name == '\0' ? std::string("(temporary database)") : std::string(name);
}

// A statement of the host connection, prepared from `sql` or a QueryError.
void prepare(Stmt& s, sqlite3* db, const std::string& sql) {
  const std::string err = s.prepare(db, sql.c_str());
  if (!err.empty()) throw QueryError{"samples: " + file_name(db) + ": " + err};
}

// sqlite3_step, a QueryError for anything but a row or the end.
bool step(sqlite3* db, sqlite3_stmt* s) {
  const int rc = sqlite3_step(s);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  throw QueryError{"samples: " + file_name(db) + ": " + sqlite3_errmsg(db)};
}

std::string text(sqlite3_stmt* s, int c) {
  const auto* t = reinterpret_cast<const char*>(sqlite3_column_text(s, c));
  return t == nullptr ? std::string() : std::string(t);
}

// The chunks of one (trial, instrument) that passed every check, one
// loaded at a time and read a window at a time, in tick order.
class ChunkStream {
 public:
  static constexpr std::size_t kWindow = 4096;

  void open(sqlite3* db, std::vector<ChunkRow> rows) {
    db_ = db;
    rows_ = std::move(rows);
    if (blob_.get() == nullptr) prepare(blob_, db, "SELECT data FROM main.sample_chunk WHERE id = ?1");
    row_ = 0;
    window_.clear();
    pos_ = 0;
    done_ = false;
    fill();
  }
  // No rows: the instrument is not asked for.
  void close() noexcept {
    rows_.clear();
    window_.clear();
    pos_ = 0;
    done_ = true;
  }
  bool done() const noexcept { return done_; }
  const StoredSample& current() const noexcept { return window_[pos_]; }
  void advance() {
    if (++pos_ < window_.size()) return;
    fill();
  }

 private:
  // The next window: the rest of the loaded chunk, or the next chunk's first.
  void fill() {
    window_.clear();
    pos_ = 0;
    while (read_ >= chunk_.size()) {
      if (row_ >= rows_.size()) {
        done_ = true;
        return;
      }
      const ChunkRow& r = rows_[row_++];
      sqlite3_reset(blob_.get());
      sqlite3_bind_int64(blob_.get(), 1, r.id);
      if (!step(db_, blob_.get()))
        throw QueryError{"samples: " + file_name(db_) + ": sample chunk row " + std::to_string(r.id) + " vanished"};
      const auto* data = static_cast<const std::byte*>(sqlite3_column_blob(blob_.get(), 0));
      const auto size = static_cast<std::size_t>(sqlite3_column_bytes(blob_.get(), 0));
      try {
        chunk_.load(r.place(), std::span(data, size));
      } catch (const ChunkError& e) {
        // Checked before the trial's first row (check_chunks), so only a
        // file changed since then gets here.
        throw QueryError{file_name(db_) + ": damaged sample chunk: " +
                         hapticlab::db::chunk_name(r.trial_id, r.instrument, r.first_tick, r.count) + ": " +
                         e.what()};
      }
      read_ = 0;
    }
    const std::size_t n = std::min(kWindow, chunk_.size() - read_);
    window_.resize(n);
    chunk_.read(read_, read_ + n, window_.data());
    read_ += n;
  }

  sqlite3* db_ = nullptr;
  Stmt blob_;
  std::vector<ChunkRow> rows_;
  std::size_t row_ = 0;
  ChunkDecoder chunk_;
  std::size_t read_ = 0;  // samples of chunk_ already windowed
  std::vector<StoredSample> window_;
  std::size_t pos_ = 0;
  bool done_ = true;
};

struct SamplesTable {
  sqlite3_vtab base;  // first: SQLite sees a sqlite3_vtab*
  sqlite3* db;
};

// One scan: the trials to visit (one, or every trial with samples), and in
// each the chunks of one or both instruments merged by tick, left first
// within a tick (the order of `hapticlab export`).
struct SamplesCursor {
  sqlite3_vtab_cursor base;  // first: SQLite sees a sqlite3_vtab_cursor*
  sqlite3* db = nullptr;
  Stmt trials;             // every trial with samples, when no trial was given
  bool one_trial = false;  // a trial was given: no `trials` statement
  bool eof = true;
  std::int64_t trial = 0;
  int only_instrument = -1;  // 0 or 1, or -1 for both
  ChunkStream stream[2];
  int row_instrument = 0;  // the stream the current row comes from
  std::int64_t rowid = 0;
};

// The rows of `table` (restricted by `where`, with ?1 bound to `trial`)
// whose values do not have their column's type, as a QueryError naming the
// first few (db/schema_shape.h).
void check_value_types(sqlite3* db, const TableShape& table, const char* where, std::int64_t trial) {
  Stmt s;
  prepare(s, db, hapticlab::db::mistyped_rows_sql(table, where, 5));
  sqlite3_bind_int64(s.get(), 1, trial);
  std::string found;
  std::vector<std::string> types(table.columns.size()), values(table.columns.size());
  while (step(db, s.get())) {
    const std::int64_t rowid = sqlite3_column_int64(s.get(), 0);
    std::optional<std::int64_t> row_trial;
    if (sqlite3_column_type(s.get(), 1) != SQLITE_NULL) row_trial = sqlite3_column_int64(s.get(), 1);
    for (std::size_t c = 0; c < table.columns.size(); ++c) {
      types[c] = text(s.get(), static_cast<int>(2 + 2 * c));
      values[c] = text(s.get(), static_cast<int>(3 + 2 * c));
    }
    found += (found.empty() ? "" : "; ") + hapticlab::db::mistyped_row_message(table, rowid, row_trial, types, values);
  }
  if (!found.empty())
    throw QueryError{file_name(db) + ": trial " + std::to_string(trial) + " cannot be read: " + found +
                     " (`hapticlab study check --db FILE` lists every finding)"};
}

bool trial_exists(sqlite3* db, std::int64_t trial) {
  Stmt s;
  prepare(s, db, "SELECT 1 FROM main.trial WHERE id = ?1");
  sqlite3_bind_int64(s.get(), 1, trial);
  return step(db, s.get());
}

// The trial's own row and what it refers to: every value of its row, its
// events and its chunk rows of the right type, and its participant,
// setting and session (when it has one) present. A trial whose participant
// is gone would vanish from every join with it.
void check_trial_row(sqlite3* db, std::int64_t trial, bool asked) {
  check_value_types(db, *hapticlab::db::find_schema_table("trial"), "rowid = ?1", trial);
  Stmt s;
  prepare(s, db,
          "SELECT t.participant_id, p.id IS NULL, t.setting_id, st.id IS NULL, t.session_id, "
          "t.session_id IS NOT NULL AND se.id IS NULL, p.study_id IS NOT NULL AND sy.id IS NULL "
          "FROM main.trial t LEFT JOIN main.participant p ON p.id = t.participant_id "
          "LEFT JOIN main.setting st ON st.id = t.setting_id LEFT JOIN main.session se ON se.id = t.session_id "
          "LEFT JOIN main.study sy ON sy.id = p.study_id WHERE t.id = ?1");
  sqlite3_bind_int64(s.get(), 1, trial);
  if (!step(db, s.get()))
    throw QueryError{asked ? "samples(): trial_id is " + std::to_string(trial) + ", but the study database " +
                                 file_name(db) + " has no such trial (see `SELECT id FROM trial`)"
                           : file_name(db) + ": sample chunks refer to trial " + std::to_string(trial) +
                                 ", which the file does not have (`hapticlab study check --db FILE` lists every "
                                 "finding)"};
  std::string found;
  const auto broken = [&](int flag, int value, const char* column, const char* parent) {
    if (sqlite3_column_int(s.get(), flag) == 0) return;
    found += (found.empty() ? "" : "; ") +
             hapticlab::db::broken_reference_message("trial", trial, trial, column, text(s.get(), value), parent);
  };
  broken(1, 0, "participant_id", "participant");
  broken(3, 2, "setting_id", "setting");
  broken(5, 4, "session_id", "session");
  if (sqlite3_column_int(s.get(), 6) != 0)
    found += (found.empty() ? "" : "; ") + std::string("trial ") + std::to_string(trial) +
             ": its participant's study_id refers to no study row";
  if (!found.empty())
    throw QueryError{file_name(db) + ": trial " + std::to_string(trial) + " cannot be read: " + found +
                     " (`hapticlab study check --db FILE` lists every finding)"};
  check_value_types(db, *hapticlab::db::find_schema_table("event"), "trial_id = ?1", trial);
}

// The trial's chunks, every check made before its first row, so a damaged
// trial gives an error and no row at all rather than rows up to the
// damage: the rows' types and places (db/chunk_layout.h), then every chunk
// of the instruments asked for verified and decompressed (checksum, frame
// checksum, structure; not decoded). Returns each instrument's good rows.
std::array<std::vector<ChunkRow>, 2> check_chunks(SamplesCursor& c) {
  Stmt s;
  prepare(s, c.db, hapticlab::db::chunk_rows_sql());
  sqlite3_bind_int64(s.get(), 1, c.trial);
  std::vector<ChunkRow> rows;
  while (step(c.db, s.get())) {
    ChunkRow r;
    r.id = sqlite3_column_int64(s.get(), 0);
    r.trial_id = sqlite3_column_int64(s.get(), 1);
    r.instrument = sqlite3_column_int64(s.get(), 2);
    r.first_tick = sqlite3_column_int64(s.get(), 3);
    r.count = sqlite3_column_int64(s.get(), 4);
    for (int k = 0; k < 5; ++k) r.types[k] = text(s.get(), 5 + k);
    for (int k = 0; k < 4; ++k) r.values[k] = text(s.get(), 10 + k);
    // samples(t, k) reads instrument k alone: the other's chunks are not its concern.
    if (c.only_instrument >= 0 && r.instrument != c.only_instrument) continue;
    rows.push_back(std::move(r));
  }
  std::vector<BadChunk> bad;
  hapticlab::db::ChunkLayout layout = hapticlab::db::layout_chunks(std::move(rows), bad);
  Stmt blob;
  prepare(blob, c.db, "SELECT data FROM main.sample_chunk WHERE id = ?1");
  ChunkDecoder decoder;
  for (const auto& instrument : layout.instrument) {
    for (const ChunkRow& r : instrument) {
      sqlite3_reset(blob.get());
      sqlite3_bind_int64(blob.get(), 1, r.id);
      if (!step(c.db, blob.get())) continue;
      const auto* data = static_cast<const std::byte*>(sqlite3_column_blob(blob.get(), 0));
      const auto size = static_cast<std::size_t>(sqlite3_column_bytes(blob.get(), 0));
      try {
        decoder.check(r.place(), std::span(data, size));
      } catch (const ChunkError& e) {
        bad.push_back({r.trial_id, r.instrument, r.first_tick, r.count, e.kind(), e.what()});
      }
    }
  }
  if (!bad.empty())
    throw QueryError{file_name(c.db) + ": damaged sample chunk: " + hapticlab::db::describe(bad.front()) +
                     (bad.size() > 1 ? " (and " + std::to_string(bad.size() - 1) + " more)" : "") +
                     "; no row of the trial is returned (`hapticlab study check --db FILE` lists every damaged "
                     "chunk)"};
  return {std::move(layout.instrument[0]), std::move(layout.instrument[1])};
}

// Picks the stream with the next row (lowest tick, left first); eof when
// both are done.
void choose_row(SamplesCursor& c) {
  const bool left = !c.stream[0].done(), right = !c.stream[1].done();
  if (!left && !right) {
    c.eof = true;
    return;
  }
  c.row_instrument = !right || (left && c.stream[0].current().tick <= c.stream[1].current().tick) ? 0 : 1;
}

void start_trial(SamplesCursor& c) {
  check_trial_row(c.db, c.trial, c.one_trial);
  std::array<std::vector<ChunkRow>, 2> rows = check_chunks(c);
  for (int k = 0; k < 2; ++k) {
    if (c.only_instrument < 0 || c.only_instrument == k) c.stream[k].open(c.db, std::move(rows[static_cast<std::size_t>(k)]));
    else c.stream[k].close();
  }
}

// Moves to the next trial that has rows (scan of every trial); eof at the end.
void next_trial(SamplesCursor& c) {
  for (;;) {
    if (!step(c.db, c.trials.get())) {
      c.eof = true;
      return;
    }
    c.trial = sqlite3_column_int64(c.trials.get(), 0);
    start_trial(c);
    choose_row(c);
    if (!c.eof) return;
    c.eof = false;
  }
}

// Refuses a database this module cannot read, saying why: not a HapticLab
// study, another schema version, or tables that are not what the schema
// says (a view in a table's place is refused before any query reads it:
// it could hold anything, or never end).
void check_database(sqlite3* db) {
  Stmt s;
  prepare(s, db, "SELECT (SELECT user_version FROM pragma_user_version), "
                 "(SELECT application_id FROM pragma_application_id), "
                 "(SELECT count(*) FROM main.sqlite_schema WHERE type = 'table' AND name = 'sample_chunk')");
  if (!step(db, s.get())) throw QueryError{"samples: " + file_name(db) + ": " + sqlite3_errmsg(db)};
  const std::int64_t version = sqlite3_column_int64(s.get(), 0);
  const std::int64_t app_id = sqlite3_column_int64(s.get(), 1);
  const bool has_chunks = sqlite3_column_int64(s.get(), 2) != 0;
  if (app_id != kApplicationId || !has_chunks)
    throw QueryError{"samples: " + file_name(db) + " is not a HapticLab study database (application_id " +
                     std::to_string(app_id) + ", expected " + std::to_string(kApplicationId) +
                     " \"HLAB\"; table sample_chunk " + (has_chunks ? "present" : "absent") + ")"};
  if (version < kSchemaVersion)
    throw QueryError{"samples: " + file_name(db) + ": study database schema version " + std::to_string(version) +
                     ", this extension reads version " + std::to_string(kSchemaVersion) +
                     "; open the file once with `hapticlab analyze` (it migrates), or run `hapticlab study check`"};
  if (version > kSchemaVersion)
    throw QueryError{"samples: " + file_name(db) + ": study database schema version " + std::to_string(version) +
                     " is newer than this extension reads (" + std::to_string(kSchemaVersion) +
                     "); use the hapticlab_sqlite of a newer HapticLab"};
  Stmt kind, columns;
  prepare(kind, db, "SELECT type FROM main.sqlite_schema WHERE name = ?1 COLLATE NOCASE AND type IN ('table', 'view') "
                    "LIMIT 1");
  prepare(columns, db, "SELECT name, type, \"notnull\" FROM pragma_table_info(?1, 'main') ORDER BY cid");
  for (const TableShape& table : hapticlab::db::schema_tables()) {
    sqlite3_reset(kind.get());
    sqlite3_bind_text(kind.get(), 1, table.name, -1, SQLITE_STATIC);
    const std::string type = step(db, kind.get()) ? text(kind.get(), 0) : std::string();
    std::vector<hapticlab::db::FoundColumn> found;
    if (type == "table") {
      sqlite3_reset(columns.get());
      sqlite3_bind_text(columns.get(), 1, table.name, -1, SQLITE_STATIC);
      while (step(db, columns.get()))
        found.push_back({text(columns.get(), 0), text(columns.get(), 1), sqlite3_column_int(columns.get(), 2) != 0});
    }
    const std::string problem = hapticlab::db::shape_problem(table, type, found);
    if (!problem.empty()) throw QueryError{"samples: " + file_name(db) + ": " + problem};
  }
}

// An argument that is an integer, or a real equal to one ("3.0"); anything
// else (NULL, 3.5, 'x') matches no row, as `trial_id = 3.5` would.
bool integer_argument(sqlite3_value* v, std::int64_t& out) {
  const int type = sqlite3_value_numeric_type(v);
  if (type == SQLITE_INTEGER) {
    out = sqlite3_value_int64(v);
    return true;
  }
  if (type == SQLITE_FLOAT) {
    const double d = sqlite3_value_double(v);
    if (d >= -9.2e18 && d <= 9.2e18 && d == std::trunc(d)) {
      out = static_cast<std::int64_t>(d);
      return true;
    }
  }
  return false;
}

void set_error(sqlite3_vtab* vtab, const std::string& message) {
  sqlite3_free(vtab->zErrMsg);
  vtab->zErrMsg = sqlite3_mprintf("%s", message.c_str());
}

// Runs `body`, turning any exception into an SQLite error on `vtab`.
template <typename Body>
int guarded(sqlite3_vtab* vtab, Body body) noexcept {
  try {
    body();
    return SQLITE_OK;
  } catch (const QueryError& e) {
    set_error(vtab, e.message);
  } catch (const std::bad_alloc&) {
    return SQLITE_NOMEM;
  } catch (const std::exception& e) {
    set_error(vtab, std::string("samples: ") + e.what());
  } catch (...) {
    set_error(vtab, "samples: unexpected error");
  }
  return SQLITE_ERROR;
}

SamplesCursor& cursor_of(sqlite3_vtab_cursor* cur) { return *reinterpret_cast<SamplesCursor*>(cur); }

int x_connect(sqlite3* db, void*, int, const char* const*, sqlite3_vtab** out, char** err) {
  const int rc = sqlite3_declare_vtab(db, create_table_sql().c_str());
  if (rc != SQLITE_OK) {
    *err = sqlite3_mprintf("samples: %s", sqlite3_errmsg(db));
    return rc;
  }
  auto* table = static_cast<SamplesTable*>(sqlite3_malloc(sizeof(SamplesTable)));
  if (table == nullptr) return SQLITE_NOMEM;
  *table = {};
  table->db = db;
  *out = &table->base;
  sqlite3_vtab_config(db, SQLITE_VTAB_INNOCUOUS);
  return SQLITE_OK;
}

int x_disconnect(sqlite3_vtab* vtab) {
  sqlite3_free(vtab);
  return SQLITE_OK;
}

// Uses an equality on trial_id and on instrument, from the function's
// arguments (hidden columns) or from WHERE on the visible columns. A scan of
// every trial costs far more, so a join such as `FROM trial t, samples(t.id)`
// is planned trial by trial.
int x_best_index(sqlite3_vtab*, sqlite3_index_info* info) {
  int trial = -1, instrument = -1;  // index into aConstraint
  bool trial_is_arg = false, instrument_is_arg = false;
  for (int i = 0; i < info->nConstraint; ++i) {
    const auto& c = info->aConstraint[i];
    // An argument of samples(...) that is not usable yet (it comes from a
    // table not scanned yet, as in `FROM trial t, samples(t.id)`): refuse
    // this plan, so SQLite scans that table first and calls us per value.
    // Without this, the planner may decode every trial of the file and
    // filter afterwards.
    const bool argument = c.iColumn == kColArgTrial || c.iColumn == kColArgInstrument;
    if (argument && !c.usable && c.op == SQLITE_INDEX_CONSTRAINT_EQ) return SQLITE_CONSTRAINT;
    if (!c.usable || c.op != SQLITE_INDEX_CONSTRAINT_EQ) continue;
    if (c.iColumn == kColArgTrial || (c.iColumn == kColTrial && trial < 0)) {
      trial = i;
      trial_is_arg = c.iColumn == kColArgTrial;
    }
    if (c.iColumn == kColArgInstrument || (c.iColumn == kColInstrument && instrument < 0)) {
      instrument = i;
      instrument_is_arg = c.iColumn == kColArgInstrument;
    }
  }
  int argv = 0;
  info->idxNum = 0;
  if (trial >= 0) {
    info->idxNum |= kHasTrial | (trial_is_arg ? kTrialFromArgs : 0);
    info->aConstraintUsage[trial].argvIndex = ++argv;
    info->aConstraintUsage[trial].omit = 1;
  }
  if (instrument >= 0) {
    info->idxNum |= kHasInstrument | (instrument_is_arg ? kInstrumentFromArgs : 0);
    info->aConstraintUsage[instrument].argvIndex = ++argv;
    info->aConstraintUsage[instrument].omit = 1;
  }
  // Rows: about 2 x 1000 per second of a trial; a study has hundreds of trials.
  const double per_trial = instrument >= 0 ? 1e5 : 2e5;
  info->estimatedRows = static_cast<sqlite3_int64>(trial >= 0 ? per_trial : per_trial * 300);
  info->estimatedCost = static_cast<double>(info->estimatedRows);
  return SQLITE_OK;
}

int x_open(sqlite3_vtab* vtab, sqlite3_vtab_cursor** out) {
  auto* c = new (std::nothrow) SamplesCursor();
  if (c == nullptr) return SQLITE_NOMEM;
  c->db = reinterpret_cast<SamplesTable*>(vtab)->db;
  *out = &c->base;
  return SQLITE_OK;
}

int x_close(sqlite3_vtab_cursor* cur) {
  delete &cursor_of(cur);
  return SQLITE_OK;
}

int x_filter(sqlite3_vtab_cursor* cur, int idx_num, const char*, int argc, sqlite3_value** argv) {
  SamplesCursor& c = cursor_of(cur);
  return guarded(cur->pVtab, [&] {
    c.eof = true;
    c.rowid = 0;
    c.trials.finalize();
    check_database(c.db);
    int arg = 0;
    std::int64_t trial = 0, instrument = -1;
    if ((idx_num & kHasTrial) && (arg >= argc || !integer_argument(argv[arg++], trial))) return;
    if (idx_num & kHasInstrument) {
      if (arg >= argc) return;
      sqlite3_value* v = argv[arg++];
      const bool ok = integer_argument(v, instrument) && (instrument == 0 || instrument == 1);
      // In samples(t, k) an instrument other than 0 or 1 is a mistake worth
      // naming; in `WHERE instrument = 2` it just matches nothing.
      if (!ok && (idx_num & kInstrumentFromArgs) && sqlite3_value_type(v) != SQLITE_NULL) {
        const char* text = reinterpret_cast<const char*>(sqlite3_value_text(v));
        throw QueryError{std::string("samples(): instrument is ") + (text ? text : "?") +
                         "; it must be 0 (left) or 1 (right), or left out for both"};
      }
      if (!ok) return;
    }
    c.only_instrument = static_cast<int>(instrument);
    c.eof = false;
    if (idx_num & kHasTrial) {
      c.one_trial = true;
      c.trial = trial;
      // samples(99) names the missing trial; `WHERE trial_id = 99` just
      // matches nothing, as it would on a table.
      if (!(idx_num & kTrialFromArgs) && !trial_exists(c.db, trial)) {
        c.eof = true;
        return;
      }
      start_trial(c);
      choose_row(c);
    } else {
      c.one_trial = false;
      prepare(c.trials, c.db, "SELECT DISTINCT trial_id FROM main.sample_chunk ORDER BY trial_id");
      next_trial(c);
    }
  });
}

int x_next(sqlite3_vtab_cursor* cur) {
  SamplesCursor& c = cursor_of(cur);
  return guarded(cur->pVtab, [&] {
    ++c.rowid;
    c.stream[c.row_instrument].advance();
    choose_row(c);
    if (c.eof && !c.one_trial) {
      c.eof = false;
      next_trial(c);
    }
  });
}

int x_eof(sqlite3_vtab_cursor* cur) { return cursor_of(cur).eof ? 1 : 0; }

int x_column(sqlite3_vtab_cursor* cur, sqlite3_context* ctx, int col) {
  const SamplesCursor& c = cursor_of(cur);
  const StoredSample& s = c.stream[c.row_instrument].current();
  if (col == kColTrial || col == kColArgTrial) {
    sqlite3_result_int64(ctx, c.trial);
  } else if (col == kColInstrument || col == kColArgInstrument) {
    sqlite3_result_int(ctx, c.row_instrument);
  } else if (col == kColTick) {
    sqlite3_result_int64(ctx, static_cast<sqlite3_int64>(s.tick));
  } else {
    const auto ch = static_cast<std::size_t>(col - kColFirstChannel);
    // SQLite has no NaN: a NaN channel comes out as NULL.
    if (ch == kChDt) sqlite3_result_double(ctx, s.dt_s);
    else if (ch == kChT) sqlite3_result_double(ctx, s.t_s);
    else if (ch < kChEngineStatus) sqlite3_result_double(ctx, float_channel(s, ch));
    else if (ch == kChEngineStatus) sqlite3_result_int64(ctx, s.value.engine_status);
    else if (ch == kChDeviceStatus) sqlite3_result_int(ctx, s.device_status);
    else if (ch == kChInContact) sqlite3_result_int(ctx, s.value.in_contact ? 1 : 0);
    else sqlite3_result_null(ctx);
  }
  return SQLITE_OK;
}

int x_rowid(sqlite3_vtab_cursor* cur, sqlite3_int64* rowid) {
  *rowid = cursor_of(cur).rowid;
  return SQLITE_OK;
}

sqlite3_module make_module() {
  sqlite3_module m{};
  m.iVersion = 0;
  m.xCreate = nullptr;  // eponymous only: samples(...) needs no CREATE VIRTUAL TABLE
  m.xConnect = x_connect;
  m.xBestIndex = x_best_index;
  m.xDisconnect = x_disconnect;
  m.xDestroy = nullptr;
  m.xOpen = x_open;
  m.xClose = x_close;
  m.xFilter = x_filter;
  m.xNext = x_next;
  m.xEof = x_eof;
  m.xColumn = x_column;
  m.xRowid = x_rowid;
  return m;
}
const sqlite3_module kSamplesModule = make_module();

}  // namespace

// The entry point SQLite looks for by default for "hapticlab_sqlite.so":
// sqlite3_X_init with X the letters of the file name ("hapticlabsqlite").
extern "C" __attribute__((visibility("default"))) int sqlite3_hapticlabsqlite_init(
    sqlite3* db, char** err, const sqlite3_api_routines* api) {
  SQLITE_EXTENSION_INIT2(api);
  const int rc = sqlite3_create_module(db, "samples", &kSamplesModule, nullptr);
  if (rc != SQLITE_OK && err != nullptr) *err = sqlite3_mprintf("hapticlab_sqlite: %s", sqlite3_errmsg(db));
  return rc;
}
