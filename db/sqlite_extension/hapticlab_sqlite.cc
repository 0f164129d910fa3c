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
#include "db/sqlite_extension/host_sql.h"
#include "db/sqlite_extension/study_checks.h"

namespace {

using namespace hapticlab::sqlite_ext;

using hapticlab::db::ChunkDecoder;
using hapticlab::db::ChunkError;
using hapticlab::db::ChunkRow;
using hapticlab::db::kChannelNames;
using hapticlab::db::kChunkChannels;
using hapticlab::db::StoredSample;

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
  std::array<std::vector<ChunkRow>, 2> rows = check_chunks(c.db, c.trial, c.only_instrument);
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
    if (idx_num & kHasTrial) {
      if (arg >= argc) return;
      sqlite3_value* v = argv[arg++];
      if (!integer_argument(v, trial)) {
        // In samples(t) a trial that is no trial id is a mistake worth
        // naming (no rows would read as an empty trial); in
        // `WHERE trial_id = 3.5` it just matches nothing.
        // (NULL matches nothing, as trial_id = NULL would.)
        if (!(idx_num & kTrialFromArgs) || sqlite3_value_type(v) == SQLITE_NULL) return;
        const char* text = reinterpret_cast<const char*>(sqlite3_value_text(v));
        throw QueryError{std::string("samples(): trial_id is ") + (text ? text : "?") +
                         "; it must be an integer, the id of a trial"};
      }
    }
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
