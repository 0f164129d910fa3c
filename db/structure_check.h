#pragma once
// What a study file must be beyond what SQLite's integrity_check proves
// (pages, indexes): its tables are tables of the schema's shape, every
// reference points at a row, and every value has its column's type. Each
// problem is a Finding that names the table, the row, the trial it belongs
// to and what is wrong, so `study check` can list them all and a reader can
// refuse the file saying why.
//
// The table check reads sqlite_master and table_info only (microseconds),
// so StudyDb runs it at every open, before any query could read a view put
// in a table's place (a recursive view never ends). The reference and type
// checks read every row of every table (record headers, not the blobs: a
// fraction of integrity_check's cost); StudyDb runs them whenever it runs an
// integrity check. A chunk's place among its trial's other chunks is
// chunk_layout.h's.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "db/schema.h"
#include "db/sqlite_handle.h"

namespace hapticlab::db {

struct Finding {
  std::string check;    // "integrity", "schema", "foreign_key", "type", "edited", "chunk"
  std::string table;    // the table concerned, if one
  std::optional<std::int64_t> row;       // its rowid
  std::optional<std::int64_t> trial_id;  // the trial the row belongs to, if any
  std::optional<std::int64_t> instrument;  // for chunk findings
  std::string message;  // names the table, row, trial, column, value and rule
};

// Every table of schema `version` (schema.h) is a table: not missing, not
// a view; at the current version it also has the expected columns
// (schema_shape.h). Reads sqlite_master and table_info only.
std::vector<Finding> check_tables(Database& db, int version);

// PRAGMA foreign_key_check, each broken reference named with its column and
// value ("trial 5: participant_id 9 refers to no participant row"), then the
// references that exist but do not fit: a trial in another participant's
// session, a trial running in a session that has ended, a trial or training
// of a task its protocol does not name, an action on a trial of another
// session; at most `limit`. Needs check_tables to have passed.
std::vector<Finding> check_foreign_keys(Database& db, std::size_t limit = 100);

// Every value of every table of the current schema has its column's type
// ("event row 17 of trial 3: t_s is text 'nan', expected a REAL") and keeps
// the schema's CHECKs (value_rules.h: "trial 3: status is 'done', which
// breaks CHECK (...)"); at most `limit` rows per table and rule. Needs
// check_tables to have passed. `version`: the file's schema version; an
// older file (a site file a merge reads as it is) is checked on the tables
// and columns it has.
std::vector<Finding> check_value_types(Database& db, std::size_t limit = 20, int version = kSchemaVersion);

// Throws DbError naming the file, the number of findings and the first few
// of them; returns when there are none.
void refuse_findings(const Database& db, const std::vector<Finding>& findings);

}  // namespace hapticlab::db
