#pragma once
// What the extension checks before it returns a row (study_checks.cc), each
// failure a QueryError naming the file and the rule (host_sql.h).

#include <array>
#include <cstdint>
#include <vector>

#include "db/chunk_layout.h"
#include "db/sqlite_extension/host_sql.h"

namespace hapticlab::sqlite_ext {

// Refuses a database this module cannot read, saying why: not a HapticLab
// study, another schema version, or tables that are not what the schema
// says (a view in a table's place is refused before any query reads it:
// it could hold anything, or never end).
void check_database(sqlite3* db);

bool trial_exists(sqlite3* db, std::int64_t trial);

// The trial's own row and what it refers to: every value of its row, its
// events and its chunk rows of the right type, and its participant,
// setting and session (when it has one) present. `asked`: the trial was
// given as samples()' argument (the message says so).
void check_trial_row(sqlite3* db, std::int64_t trial, bool asked);

// The trial's chunks (of instrument `only_instrument`, or both when -1),
// every check made before its first row: the rows' types and places, then
// every chunk verified and decompressed. Returns each instrument's rows.
std::array<std::vector<db::ChunkRow>, 2> check_chunks(sqlite3* db, std::int64_t trial, int only_instrument);

}  // namespace hapticlab::sqlite_ext
