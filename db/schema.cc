#include "db/schema.h"

#include <cstdint>
#include <string>
#include <vector>

#include "core/common/sha256.h"
#include "db/sample_codec.h"

namespace hapticlab::db {
namespace {

// Version 1: the first layout. Loop timing was not stored, only the number
// of dropped samples, as a column of trial; training was not recorded.
constexpr const char* kV1 = R"sql(
CREATE TABLE study (
  id               INTEGER PRIMARY KEY,
  name             TEXT NOT NULL UNIQUE,
  protocol_json    TEXT NOT NULL,
  protocol_sha256  TEXT NOT NULL CHECK (length(protocol_sha256) = 64),
  seed             TEXT NOT NULL,
  software_version TEXT NOT NULL,
  created_utc      TEXT NOT NULL
);
CREATE TABLE participant (
  id       INTEGER PRIMARY KEY,
  study_id INTEGER NOT NULL REFERENCES study (id),
  code     TEXT NOT NULL,
  UNIQUE (study_id, code)
);
CREATE TABLE setting (
  id              INTEGER PRIMARY KEY,
  study_id        INTEGER NOT NULL REFERENCES study (id),
  name            TEXT NOT NULL,
  parameters_json TEXT NOT NULL,
  UNIQUE (study_id, name)
);
CREATE TABLE session (
  id             INTEGER PRIMARY KEY,
  participant_id INTEGER NOT NULL REFERENCES participant (id),
  started_unix_s REAL NOT NULL,
  ended_unix_s   REAL,
  device         TEXT NOT NULL,
  clock          TEXT NOT NULL CHECK (clock IN ('virtual', 'wall')),
  status         TEXT NOT NULL CHECK (status IN ('open', 'closed', 'interrupted'))
);
CREATE TABLE trial (
  id              INTEGER PRIMARY KEY,
  participant_id  INTEGER NOT NULL REFERENCES participant (id),
  task            TEXT NOT NULL,
  setting_id      INTEGER NOT NULL REFERENCES setting (id),
  repetition      INTEGER NOT NULL,
  block           INTEGER NOT NULL,
  position        INTEGER NOT NULL,
  status          TEXT NOT NULL DEFAULT 'planned'
                  CHECK (status IN ('planned', 'running', 'complete', 'aborted')),
  session_id      INTEGER REFERENCES session (id),
  started_unix_s  REAL,
  ended_unix_s    REAL,
  abort_reason    TEXT,
  dropped_samples INTEGER NOT NULL DEFAULT 0,
  UNIQUE (participant_id, position)
);
CREATE TABLE sample_chunk (
  id         INTEGER PRIMARY KEY,
  trial_id   INTEGER NOT NULL REFERENCES trial (id),
  instrument INTEGER NOT NULL CHECK (instrument IN (0, 1)),
  first_tick INTEGER NOT NULL,
  count      INTEGER NOT NULL CHECK (count > 0),
  t0_s       REAL NOT NULL,
  data       BLOB NOT NULL,
  UNIQUE (trial_id, instrument, first_tick)
);
CREATE TABLE event (
  id         INTEGER PRIMARY KEY,
  trial_id   INTEGER NOT NULL REFERENCES trial (id),
  t_s        REAL NOT NULL,
  type       TEXT NOT NULL,
  instrument INTEGER NOT NULL CHECK (instrument IN (-1, 0, 1)),
  item_index INTEGER NOT NULL DEFAULT 0,
  detail     TEXT
);
CREATE INDEX event_by_trial ON event (trial_id, t_s);
)sql";

// Version 2: loop timing per trial gets its own table, and the drop count
// moves there from trial (timing columns stay NULL for trials recorded
// before: it was not measured); training periods are recorded.
constexpr const char* kV2 = R"sql(
CREATE TABLE training (
  id             INTEGER PRIMARY KEY,
  session_id     INTEGER NOT NULL REFERENCES session (id),
  task           TEXT NOT NULL,
  started_unix_s REAL NOT NULL,
  ended_unix_s   REAL,
  duration_s     REAL,
  trials         INTEGER NOT NULL DEFAULT 0
);
CREATE TABLE loop_timing (
  trial_id         INTEGER PRIMARY KEY REFERENCES trial (id),
  count            INTEGER,
  p50_period_s     REAL,
  p99_period_s     REAL,
  max_period_s     REAL,
  mean_period_s    REAL,
  overruns         INTEGER,
  rejected_periods INTEGER,
  dropped_samples  INTEGER NOT NULL DEFAULT 0,
  dropped_events   INTEGER NOT NULL DEFAULT 0
);
INSERT INTO loop_timing (trial_id, dropped_samples)
  SELECT id, dropped_samples FROM trial
  WHERE status IN ('complete', 'aborted') OR dropped_samples <> 0;
ALTER TABLE trial DROP COLUMN dropped_samples;
)sql";

// Version 3: an aborted trial is re-queued as a planned copy at the same
// position, so (participant, position) is unique only among trials that are
// not aborted. SQLite cannot drop a table constraint, so trial is rebuilt
// (the documented 12-step procedure: migrate() turns foreign keys off around
// the transaction and runs foreign_key_check before committing).
constexpr const char* kV3 = R"sql(
CREATE TABLE trial_v3 (
  id             INTEGER PRIMARY KEY,
  participant_id INTEGER NOT NULL REFERENCES participant (id),
  task           TEXT NOT NULL,
  setting_id     INTEGER NOT NULL REFERENCES setting (id),
  repetition     INTEGER NOT NULL,
  block          INTEGER NOT NULL,
  position       INTEGER NOT NULL,
  status         TEXT NOT NULL DEFAULT 'planned'
                 CHECK (status IN ('planned', 'running', 'complete', 'aborted')),
  session_id     INTEGER REFERENCES session (id),
  started_unix_s REAL,
  ended_unix_s   REAL,
  abort_reason   TEXT
);
INSERT INTO trial_v3 (id, participant_id, task, setting_id, repetition, block, position, status, session_id,
                      started_unix_s, ended_unix_s, abort_reason)
  SELECT id, participant_id, task, setting_id, repetition, block, position, status, session_id,
         started_unix_s, ended_unix_s, abort_reason FROM trial;
DROP TABLE trial;
ALTER TABLE trial_v3 RENAME TO trial;
CREATE UNIQUE INDEX trial_live_position ON trial (participant_id, position) WHERE status <> 'aborted';
CREATE INDEX trial_by_participant ON trial (participant_id, status, position, id);
)sql";

// Version 4: every sample chunk blob carries a CRC-32C (sample_codec.h).
// The blobs written before get theirs here, as format 0, which says that
// the checksum dates from this migration and not from the writing: damage
// done before it cannot be told from data. No table changes.
constexpr const char* kV4 = "";

void checksum_old_chunks(Database& db) {
  // Row by row (ids first): a blob is rewritten while no statement is
  // stepping over its table, and only one blob is in memory at a time.
  std::vector<std::int64_t> ids;
  {
    Statement s = db.prepare("SELECT id FROM sample_chunk ORDER BY id");
    while (s.step()) ids.push_back(s.column_int64(0));
  }
  Statement read = db.prepare("SELECT first_tick, count, data FROM sample_chunk WHERE id = ?1");
  Statement write = db.prepare("UPDATE sample_chunk SET data = ?2 WHERE id = ?1");
  for (const std::int64_t id : ids) {
    read.reset();
    read.bind(1, id);
    read.step();
    const std::vector<std::byte> blob = checksum_legacy_chunk(
        static_cast<std::uint64_t>(read.column_int64(0)), static_cast<std::size_t>(read.column_int64(1)),
        read.column_blob(2));
    write.reset();
    write.bind(1, id).bind_blob(2, blob);
    write.run();
  }
}

// Version 5: what a device counted during a trial (the UDP bridge's lost,
// stale and malformed packets, ...), one row per counter; the names are the
// device's (Device::counters()).
constexpr const char* kV5 = R"sql(
CREATE TABLE device_counter (
  trial_id INTEGER NOT NULL REFERENCES trial (id),
  name     TEXT NOT NULL,
  value    INTEGER NOT NULL,
  PRIMARY KEY (trial_id, name)
);
)sql";

// Version 6: the operator's actions (the console's note, pause, rest,
// next, end-training, abort and STOP), each stored when it is accepted,
// before the console answers: with its session (none for a STOP while no
// session runs) and the trial running then (none between trials), so an
// action survives a session stopped before its next trial and a killed
// console. The runner's own effect events (operator_abort at loop time)
// stay in event.
constexpr const char* kV6 = R"sql(
CREATE TABLE operator_action (
  id         INTEGER PRIMARY KEY,
  session_id INTEGER REFERENCES session (id),
  trial_id   INTEGER REFERENCES trial (id),
  unix_s     REAL NOT NULL,
  t_s        REAL,
  type       TEXT NOT NULL,
  detail     TEXT NOT NULL DEFAULT ''
);
CREATE INDEX operator_action_by_session ON operator_action (session_id, id);
)sql";

// Version 7: a chunk's checksum covers where it belongs -- trial,
// instrument, first tick, count -- and format 3's zstd frame carries its
// content checksum (sample_codec.h). Every chunk is rewritten: its schema-6
// checksum verified and the chunk decoded in full, then format 2 becomes
// format 3 (the same body, recompressed with the frame checksum; formats 0
// and 1 keep their bytes) and the new checksum is computed over its row.
// A chunk that fails then is left exactly as it was: under the new scheme
// it stays damaged (its old checksum does not match), so the damage found
// now is not certified. No table changes. db/README.md ("Why the migration
// rewrites the chunks") argues for rewriting over reading both kinds.
constexpr const char* kV7 = "";

void checksum_chunk_places(Database& db) {
  // Row by row, as version 4's step: one blob in memory at a time.
  std::vector<std::int64_t> ids;
  {
    Statement s = db.prepare("SELECT id FROM sample_chunk ORDER BY id");
    while (s.step()) ids.push_back(s.column_int64(0));
  }
  Statement read = db.prepare("SELECT trial_id, instrument, first_tick, count, data FROM sample_chunk WHERE id = ?1");
  Statement write = db.prepare("UPDATE sample_chunk SET data = ?2 WHERE id = ?1");
  for (const std::int64_t id : ids) {
    read.reset();
    read.bind(1, id);
    read.step();
    const ChunkPlace place{read.column_int64(0), read.column_int64(1), static_cast<std::uint64_t>(read.column_int64(2)),
                           static_cast<std::uint64_t>(read.column_int64(3))};
    std::vector<std::byte> blob;
    try {
      blob = upgrade_schema6_chunk(place, read.column_blob(4));
    } catch (const ChunkError&) {
      continue;  // damaged before the migration: kept as it is, and so still damaged
    }
    write.reset();
    write.bind(1, id).bind_blob(2, blob);
    write.run();
  }
}

// Version 8: a practice trial that ended before its task was complete (a
// time limit, the watchdog, a device fault) is counted as what it was, not
// as a training trial done: `trials` counts those done in full, `cut_short`
// the others, `cut_short_reason` why the last of them ended. Rows recorded
// before counted both in `trials` (cut_short 0: not known then).
constexpr const char* kV8 = R"sql(
ALTER TABLE training ADD COLUMN cut_short INTEGER NOT NULL DEFAULT 0;
ALTER TABLE training ADD COLUMN cut_short_reason TEXT;
)sql";

// Version 9: the site (station, hospital) whose file a session was
// recorded in, for studies merged from several sites' files (`hapticlab
// study merge`, db/study_merge.h). NULL for a session recorded in the
// study's own file and never merged: one site, the file's. Old files stay
// readable: the column is added, every existing session gets NULL.
constexpr const char* kV9 = R"sql(
ALTER TABLE session ADD COLUMN site TEXT;
)sql";

// Version 10: what a session ran on beyond its device and clock -- the
// haptic loop's rate, and the model its simulated participant was drawn
// from (core/sim/population.h describe_participant_model; NULL when no
// simulated participant held the device, a person did). Sessions of one
// study that differ in either are not comparable, which `analyze` and
// `study show` now say. Sessions recorded before: NULL, not known.
constexpr const char* kV10 = R"sql(
ALTER TABLE session ADD COLUMN rate_Hz REAL;
ALTER TABLE session ADD COLUMN participant_model TEXT;
)sql";

// Version 11: each setting's SHA-256 of its parameters_json, as the study
// has its protocol's since version 1. A session configures its engine from
// that row: an edited setting changed what later participants felt while
// the earlier ones' trials stayed in the same comparison, and nothing said
// so. Every reader of a setting now compares the two (StudyDb::setting_json,
// `study check`, `study merge`). Settings of an older file get the digest of
// their text at this migration: an edit made before it cannot be found.
constexpr const char* kV11 = R"sql(
ALTER TABLE setting ADD COLUMN parameters_sha256 TEXT NOT NULL DEFAULT '';
)sql";

void digest_settings(Database& db) {
  std::vector<std::pair<std::int64_t, std::string>> rows;
  {
    Statement s = db.prepare("SELECT id, parameters_json FROM setting ORDER BY id");
    while (s.step()) rows.emplace_back(s.column_int64(0), s.column_text(1));
  }
  Statement write = db.prepare("UPDATE setting SET parameters_sha256 = ?2 WHERE id = ?1");
  for (const auto& [id, json] : rows) {
    write.reset();
    write.bind(1, id).bind(2, sha256_hex(json));
    write.run();
  }
}

constexpr Migration kMigrations[] = {
    {1, "initial layout: study, participant, setting, session, trial, sample_chunk, event", kV1},
    {2, "loop_timing table (drop counts move out of trial), training table", kV2},
    {3, "trial: (participant, position) unique among trials not aborted, so an aborted trial can be re-queued",
     kV3},
    {4, "sample_chunk.data: a CRC-32C in every chunk; chunks written before get theirs now (format 0)", kV4,
     checksum_old_chunks},
    {5, "device_counter table: a device's own counts per trial (UDP bridge packet losses, ...)", kV5},
    {6, "operator_action table: the console operator's actions, stored when accepted", kV6},
    {7, "sample_chunk.data: the checksum covers trial and instrument, zstd frames carry their content checksum "
        "(format 3); every chunk rewritten",
     kV7, checksum_chunk_places},
    {8, "training: practice trials cut short counted apart (cut_short, cut_short_reason)", kV8},
    {9, "session.site: the site whose file a session was recorded in (multi-site merges)", kV9},
    {10, "session.rate_Hz, session.participant_model: the loop's rate and the simulated participant's model", kV10},
    {11, "setting.parameters_sha256: each setting's digest, checked wherever a setting is read", kV11,
     digest_settings},
};
static_assert(std::size(kMigrations) == kSchemaVersion);

int version_or_refuse(Database& db) {
  const std::int64_t version = db.pragma_int("user_version");
  const std::int64_t app_id = db.pragma_int("application_id");
  if (version == 0) {
    // Version 0 is an empty file, unless someone else put tables in it.
    Statement s = db.prepare("SELECT count(*) FROM sqlite_schema");
    s.step();
    if (s.column_int64(0) != 0)
      throw DbError(db.path() + ": not a HapticLab study database (it has tables but no schema version)");
    return 0;
  }
  if (app_id != kApplicationId)
    throw DbError(db.path() + ": not a HapticLab study database (application_id " + std::to_string(app_id) +
                  ", expected " + std::to_string(kApplicationId) + ")");
  if (version > kSchemaVersion)
    throw DbError(db.path() + ": database schema version " + std::to_string(version) +
                  " is newer than this HapticLab supports (" + std::to_string(kSchemaVersion) +
                  "); open it with a newer HapticLab");
  if (version < 0) throw DbError(db.path() + ": invalid schema version " + std::to_string(version));
  return static_cast<int>(version);
}

// Foreign keys off for the lifetime of the guard. The pragma is a no-op
// inside a transaction, so the guard must be made before BEGIN and dropped
// after COMMIT or ROLLBACK.
class ForeignKeysOff {
 public:
  explicit ForeignKeysOff(Database& db) : db_(db) { db_.exec("PRAGMA foreign_keys = OFF"); }
  ~ForeignKeysOff() {
    try {
      db_.exec("PRAGMA foreign_keys = ON");
    } catch (...) {
      // Destructors do not throw; a connection that cannot run a pragma
      // fails its next statement anyway.
    }
  }
  ForeignKeysOff(const ForeignKeysOff&) = delete;
  ForeignKeysOff& operator=(const ForeignKeysOff&) = delete;

 private:
  Database& db_;
};

// Rebuilding a table (step 3) must not leave a child row pointing nowhere.
void check_foreign_keys(Database& db, int found) {
  Statement s = db.prepare("PRAGMA foreign_key_check");
  if (s.step())
    throw DbError(db.path() + ": migration from schema version " + std::to_string(found) +
                  " left a broken reference (table " + s.column_text(0) + " row " + std::to_string(s.column_int64(1)) +
                  " -> " + s.column_text(2) + "), database left at version " + std::to_string(found));
}

}  // namespace

std::span<const Migration> migrations() { return kMigrations; }

int check_schema_version(Database& db) { return version_or_refuse(db); }

int migrate(Database& db) {
  if (version_or_refuse(db) == kSchemaVersion) return kSchemaVersion;
  ForeignKeysOff fk_off(db);
  Transaction tx(db);
  // Read again under the write lock: another process may have migrated
  // the file between the first look and BEGIN IMMEDIATE.
  const int found = version_or_refuse(db);
  for (const Migration& m : kMigrations) {
    if (m.to_version <= found) continue;
    try {
      db.exec(m.sql);
      if (m.convert != nullptr) m.convert(db);
    } catch (const DbError& e) {
      throw DbError(db.path() + ": migration to schema version " + std::to_string(m.to_version) + " (" +
                        m.description + ") failed, database left at version " + std::to_string(found) +
                        ": " + e.what(),
                    e.sqlite_code());
    }
  }
  check_foreign_keys(db, found);
  db.exec("PRAGMA user_version = " + std::to_string(kSchemaVersion));
  db.exec("PRAGMA application_id = " + std::to_string(kApplicationId));
  tx.commit();
  return found;
}

}  // namespace hapticlab::db
