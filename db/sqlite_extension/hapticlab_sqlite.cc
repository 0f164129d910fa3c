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

#include <cmath>
#include <cstdint>
#include <new>
#include <span>
#include <string>
#include <vector>

#include "db/sample_codec.h"

namespace {

using hapticlab::db::ChunkError;
using hapticlab::db::kChannelNames;
using hapticlab::db::kChunkChannels;
using hapticlab::db::StoredSample;

// The schemas this module reads: chunks with the 5-byte header (format 0 or
// 1) exist from version 4 on, unchanged up to this build's kSchemaVersion
// (db/schema.h; version 5 added the device_counter table, 6 the
// operator_action table).
constexpr int kOldestSchemaVersion = 4;
constexpr int kSchemaVersion = 6;
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

// "trial 3, left instrument (0), ticks 1000..1999", as db/chunk_reader.h's
// describe() and `hapticlab export` name a chunk.
std::string chunk_name(std::int64_t trial, int instrument, std::int64_t first_tick, std::int64_t count) {
  const char* hand = instrument == 0 ? "left" : instrument == 1 ? "right" : "unknown";
  std::string ticks = std::to_string(first_tick);
  if (count > 1) ticks += ".." + std::to_string(first_tick + count - 1);
  return "trial " + std::to_string(trial) + ", " + hand + " instrument (" + std::to_string(instrument) + "), ticks " +
         ticks;
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

// The chunks of one (trial, instrument), one decoded at a time, in tick order.
class ChunkStream {
 public:
  void open(sqlite3* db, std::int64_t trial, int instrument) {
    db_ = db;
    trial_ = trial;
    instrument_ = instrument;
    if (chunks_.get() == nullptr) {
      const std::string err = chunks_.prepare(
          db, "SELECT first_tick, count, data FROM sample_chunk WHERE trial_id = ?1 AND instrument = ?2 "
              "ORDER BY first_tick");
      if (!err.empty()) throw QueryError{"samples: cannot read the sample chunks: " + err};
    }
    sqlite3_reset(chunks_.get());
    sqlite3_bind_int64(chunks_.get(), 1, trial);
    sqlite3_bind_int(chunks_.get(), 2, instrument);
    chunk_.clear();
    pos_ = 0;
    done_ = false;
    next_chunk();
  }
  // No rows: the instrument is not asked for.
  void close() noexcept {
    chunk_.clear();
    pos_ = 0;
    done_ = true;
  }
  bool done() const noexcept { return done_; }
  const StoredSample& current() const noexcept { return chunk_[pos_]; }
  void advance() {
    if (++pos_ < chunk_.size()) return;
    next_chunk();
  }

 private:
  void next_chunk() {
    chunk_.clear();
    pos_ = 0;
    const int rc = sqlite3_step(chunks_.get());
    if (rc == SQLITE_DONE) {
      done_ = true;
      return;
    }
    if (rc != SQLITE_ROW) throw QueryError{std::string("samples: reading sample_chunk: ") + sqlite3_errmsg(db_)};
    const std::int64_t first = sqlite3_column_int64(chunks_.get(), 0);
    const std::int64_t count = sqlite3_column_int64(chunks_.get(), 1);
    const auto* data = static_cast<const std::byte*>(sqlite3_column_blob(chunks_.get(), 2));
    const auto size = static_cast<std::size_t>(sqlite3_column_bytes(chunks_.get(), 2));
    try {
      if (count <= 0) throw ChunkError(ChunkError::Kind::kStructure, "count is " + std::to_string(count));
      hapticlab::db::decode_chunk(static_cast<std::uint64_t>(first), static_cast<std::size_t>(count),
                                  std::span(data, size), chunk_);
    } catch (const ChunkError& e) {
      throw QueryError{"damaged sample chunk: " + chunk_name(trial_, instrument_, first, count) + ": " + e.what()};
    }
  }

  sqlite3* db_ = nullptr;
  std::int64_t trial_ = 0;
  int instrument_ = 0;
  Stmt chunks_;
  std::vector<StoredSample> chunk_;
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

// Every chunk of `trial` checked (header and CRC-32C, no decoding) before
// the trial's first row, so a damaged trial gives an error and no row at
// all rather than rows up to the damage. Costs one more read of the blobs:
// about 30 ns per update (db/README.md, "Damage").
void verify_trial(SamplesCursor& c) {
  Stmt s;
  const std::string err = s.prepare(c.db,
                                    "SELECT instrument, first_tick, count, data FROM sample_chunk "
                                    "WHERE trial_id = ?1 AND (?2 < 0 OR instrument = ?2) ORDER BY instrument, first_tick");
  if (!err.empty()) throw QueryError{"samples: cannot read the sample chunks: " + err};
  sqlite3_bind_int64(s.get(), 1, c.trial);
  sqlite3_bind_int(s.get(), 2, c.only_instrument);
  int rc;
  while ((rc = sqlite3_step(s.get())) == SQLITE_ROW) {
    const int instrument = sqlite3_column_int(s.get(), 0);
    const std::int64_t first = sqlite3_column_int64(s.get(), 1);
    const std::int64_t count = sqlite3_column_int64(s.get(), 2);
    const auto* data = static_cast<const std::byte*>(sqlite3_column_blob(s.get(), 3));
    const auto size = static_cast<std::size_t>(sqlite3_column_bytes(s.get(), 3));
    try {
      hapticlab::db::verify_chunk(static_cast<std::uint64_t>(first), static_cast<std::size_t>(count),
                                  std::span(data, size));
    } catch (const ChunkError& e) {
      throw QueryError{"damaged sample chunk: " + chunk_name(c.trial, instrument, first, count) + ": " + e.what() +
                       " (`hapticlab study check --db FILE` lists every damaged chunk)"};
    }
  }
  if (rc != SQLITE_DONE) throw QueryError{std::string("samples: reading sample_chunk: ") + sqlite3_errmsg(c.db)};
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
  verify_trial(c);
  for (int k = 0; k < 2; ++k) {
    if (c.only_instrument < 0 || c.only_instrument == k) c.stream[k].open(c.db, c.trial, k);
    else c.stream[k].close();
  }
}

// Moves to the next trial that has rows (scan of every trial); eof at the end.
void next_trial(SamplesCursor& c) {
  for (;;) {
    const int rc = sqlite3_step(c.trials.get());
    if (rc == SQLITE_DONE) {
      c.eof = true;
      return;
    }
    if (rc != SQLITE_ROW) throw QueryError{std::string("samples: reading sample_chunk: ") + sqlite3_errmsg(c.db)};
    c.trial = sqlite3_column_int64(c.trials.get(), 0);
    start_trial(c);
    choose_row(c);
    if (!c.eof) return;
    c.eof = false;
  }
}

// Refuses a database this module cannot read, saying why, instead of
// reporting every chunk of an old file as damaged.
void check_database(sqlite3* db) {
  Stmt s;
  std::string err = s.prepare(db, "SELECT (SELECT user_version FROM pragma_user_version), "
                                  "(SELECT application_id FROM pragma_application_id), "
                                  "(SELECT count(*) FROM sqlite_schema WHERE type = 'table' AND name = 'sample_chunk')");
  if (!err.empty()) throw QueryError{"samples: " + err};
  if (sqlite3_step(s.get()) != SQLITE_ROW) throw QueryError{std::string("samples: ") + sqlite3_errmsg(db)};
  const std::int64_t version = sqlite3_column_int64(s.get(), 0);
  const std::int64_t app_id = sqlite3_column_int64(s.get(), 1);
  const bool has_chunks = sqlite3_column_int64(s.get(), 2) != 0;
  if (app_id != kApplicationId || !has_chunks)
    throw QueryError{"samples: this is not a HapticLab study database (application_id " + std::to_string(app_id) +
                     ", expected " + std::to_string(kApplicationId) + " \"HLAB\"; table sample_chunk " +
                     (has_chunks ? "present" : "absent") + ")"};
  if (version < kOldestSchemaVersion)
    throw QueryError{"samples: study database schema version " + std::to_string(version) + ", this extension reads " +
                     std::to_string(kOldestSchemaVersion) + ".." + std::to_string(kSchemaVersion) +
                     "; open the file once with `hapticlab analyze` (it migrates), or run `hapticlab study check`"};
  if (version > kSchemaVersion)
    throw QueryError{"samples: study database schema version " + std::to_string(version) +
                     " is newer than this extension reads (" + std::to_string(kSchemaVersion) +
                     "); use the hapticlab_sqlite of a newer HapticLab"};
}

// samples(99) for a trial the study does not have is a mistake worth
// naming (a planned trial has no samples yet and gives no rows).
void check_trial_exists(sqlite3* db, std::int64_t trial) {
  Stmt s;
  const std::string err = s.prepare(db, "SELECT count(*) FROM trial WHERE id = ?1");
  if (!err.empty()) throw QueryError{"samples: " + err};
  sqlite3_bind_int64(s.get(), 1, trial);
  if (sqlite3_step(s.get()) != SQLITE_ROW) throw QueryError{std::string("samples: ") + sqlite3_errmsg(db)};
  if (sqlite3_column_int64(s.get(), 0) == 0)
    throw QueryError{"samples(): trial_id is " + std::to_string(trial) +
                     ", but the study database has no such trial (see `SELECT id FROM trial`)"};
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
      if (idx_num & kTrialFromArgs) check_trial_exists(c.db, trial);
      c.one_trial = true;
      c.trial = trial;
      start_trial(c);
      choose_row(c);
    } else {
      c.one_trial = false;
      const std::string err = c.trials.prepare(c.db, "SELECT DISTINCT trial_id FROM sample_chunk ORDER BY trial_id");
      if (!err.empty()) throw QueryError{"samples: cannot read the sample chunks: " + err};
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
