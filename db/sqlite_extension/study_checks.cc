// The checks the extension makes before it returns a row (study_checks.h):
// the file is a study of the schema it reads, a trial's row and what it
// refers to are sound, and every chunk of the trial verifies.
#include "db/sqlite_extension/study_checks.h"

#include <map>
#include <optional>
#include <span>

#include "db/chunk_coverage_rules.h"
#include "db/sample_codec.h"
#include "db/schema_shape.h"
#include "db/study_digest_rules.h"

namespace hapticlab::sqlite_ext {

using db::BadChunk;
using db::ChunkDecoder;
using db::ChunkError;
using db::ChunkRow;
using db::TableShape;

namespace {

// The schema this module reads: version 11 (db/schema.h); since version 7 its chunks
// checksums cover their trial and instrument. Older files are migrated by
// any HapticLab command that opens them read-write (`hapticlab analyze`).
constexpr int kSchemaVersion = 11;
constexpr std::int64_t kApplicationId = 0x484C4142;  // "HLAB"

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

}  // namespace

bool trial_exists(sqlite3* db, std::int64_t trial) {
  Stmt s;
  prepare(s, db, "SELECT 1 FROM main.trial WHERE id = ?1");
  sqlite3_bind_int64(s.get(), 1, trial);
  return step(db, s.get());
}

// A text column's bytes, all of them (text() stops at a NUL): the digest
// is of the bytes stored.
std::string stored_bytes(sqlite3_stmt* s, int c) {
  const auto* p = static_cast<const char*>(sqlite3_column_blob(s, c));
  return p == nullptr ? std::string() : std::string(p, static_cast<std::size_t>(sqlite3_column_bytes(s, c)));
}

// The trial's setting and its study's protocol match the digests stored
// with them (db/study_digest_rules.h): the samples of a trial run under an
// edited setting would be read as the setting's.
void check_definitions(sqlite3* db, std::int64_t trial) {
  check_value_types(db, *hapticlab::db::find_schema_table("setting"), "rowid = (SELECT setting_id FROM main.trial "
                                                                       "WHERE id = ?1)", trial);
  check_value_types(db, *hapticlab::db::find_schema_table("study"),
                    "rowid = (SELECT p.study_id FROM main.trial t JOIN main.participant p ON p.id = t.participant_id "
                    "WHERE t.id = ?1)", trial);
  Stmt s;
  prepare(s, db,
          "SELECT st.id, st.name, st.parameters_json, st.parameters_sha256, sy.id, sy.protocol_json, "
          "sy.protocol_sha256 FROM main.trial t JOIN main.setting st ON st.id = t.setting_id "
          "JOIN main.participant p ON p.id = t.participant_id JOIN main.study sy ON sy.id = p.study_id "
          "WHERE t.id = ?1");
  sqlite3_bind_int64(s.get(), 1, trial);
  if (!step(db, s.get())) return;  // check_trial_row named what is missing
  std::string found;
  if (const std::string digest = hapticlab::db::text_digest(stored_bytes(s.get(), 2)); digest != text(s.get(), 3))
    found = hapticlab::db::edited_setting_message(sqlite3_column_int64(s.get(), 0), text(s.get(), 1),
                                                  text(s.get(), 3), digest);
  if (const std::string digest = hapticlab::db::text_digest(stored_bytes(s.get(), 5)); digest != text(s.get(), 6))
    found += (found.empty() ? "" : "; ") + hapticlab::db::edited_protocol_message(sqlite3_column_int64(s.get(), 4),
                                                                                   text(s.get(), 6), digest);
  if (!found.empty())
    throw QueryError{file_name(db) + ": trial " + std::to_string(trial) + " cannot be read: " + found +
                     " (`hapticlab study check --db FILE` lists every finding)"};
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
  check_definitions(db, trial);
}

namespace {

// Whether the well-placed chunks hold every update the file says the trial
// stored (db/chunk_coverage_rules.h): a removed chunk is named, not read as
// a shorter trial. The layout holds the asked instrument's rows alone when
// one was asked, so only its findings count.
void check_coverage(sqlite3* db, std::int64_t trial, int only_instrument, const hapticlab::db::ChunkLayout& layout,
                    std::vector<BadChunk>& bad) {
  std::map<std::int64_t, std::int64_t> logged;
  Stmt gaps;
  prepare(gaps, db, hapticlab::db::logged_gaps_sql("main"));
  sqlite3_bind_int64(gaps.get(), 1, trial);
  while (step(db, gaps.get())) ++logged[sqlite3_column_int64(gaps.get(), 0)];
  hapticlab::db::LoopCount loop;
  Stmt timing;
  prepare(timing, db, hapticlab::db::loop_count_sql("main"));
  sqlite3_bind_int64(timing.get(), 1, trial);
  if (step(db, timing.get()))
    loop = hapticlab::db::loop_count(sqlite3_column_int64(timing.get(), 0), sqlite3_column_int64(timing.get(), 1),
                                     sqlite3_column_int64(timing.get(), 2));
  std::vector<BadChunk> found;
  hapticlab::db::add_coverage_findings(trial, layout, logged, loop, found);
  for (BadChunk& b : found)
    if (only_instrument < 0 || b.instrument == only_instrument) bad.push_back(std::move(b));
}

}  // namespace

// The trial's chunks, every check made before its first row, so a damaged
// trial gives an error and no row at all rather than rows up to the
// damage: the rows' types and places (db/chunk_layout.h), whether one is
// missing (db/chunk_coverage_rules.h), then every chunk
// of the instruments asked for verified and decompressed (checksum, frame
// checksum, structure; not decoded). Returns each instrument's good rows.
std::array<std::vector<ChunkRow>, 2> check_chunks(sqlite3* db, std::int64_t trial, int only_instrument) {
  Stmt s;
  prepare(s, db, hapticlab::db::chunk_rows_sql());
  sqlite3_bind_int64(s.get(), 1, trial);
  std::vector<ChunkRow> rows;
  while (step(db, s.get())) {
    ChunkRow r;
    r.id = sqlite3_column_int64(s.get(), 0);
    r.trial_id = sqlite3_column_int64(s.get(), 1);
    r.instrument = sqlite3_column_int64(s.get(), 2);
    r.first_tick = sqlite3_column_int64(s.get(), 3);
    r.count = sqlite3_column_int64(s.get(), 4);
    for (int k = 0; k < 5; ++k) r.types[k] = text(s.get(), 5 + k);
    for (int k = 0; k < 4; ++k) r.values[k] = text(s.get(), 10 + k);
    // samples(t, k) reads instrument k alone: the other's chunks are not its concern.
    if (only_instrument >= 0 && r.instrument != only_instrument) continue;
    rows.push_back(std::move(r));
  }
  std::vector<BadChunk> bad;
  hapticlab::db::ChunkLayout layout = hapticlab::db::layout_chunks(std::move(rows), bad);
  if (bad.empty()) check_coverage(db, trial, only_instrument, layout, bad);
  Stmt blob;
  prepare(blob, db, "SELECT data FROM main.sample_chunk WHERE id = ?1");
  ChunkDecoder decoder;
  for (const auto& instrument : layout.instrument) {
    for (const ChunkRow& r : instrument) {
      sqlite3_reset(blob.get());
      sqlite3_bind_int64(blob.get(), 1, r.id);
      if (!step(db, blob.get())) continue;
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
    throw QueryError{file_name(db) + ": damaged sample chunk: " + hapticlab::db::describe(bad.front()) +
                     (bad.size() > 1 ? " (and " + std::to_string(bad.size() - 1) + " more)" : "") +
                     "; no row of the trial is returned (`hapticlab study check --db FILE` lists every damaged "
                     "chunk)"};
  return {std::move(layout.instrument[0]), std::move(layout.instrument[1])};
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

}  // namespace hapticlab::sqlite_ext
