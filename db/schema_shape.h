#pragma once
// The shape of the current schema's tables -- their columns, declared
// types and NOT NULL -- as data, and the SQL and messages of the two checks
// built on it: a file's tables are tables of that shape (not views, not
// another layout), and the values in them hold their column's type (an
// event time is a REAL, never the TEXT 'nan' that a reader would read as 0).
//
// Pure text: no SQLite here, so the SQL extension (db/sqlite_extension/),
// which must call its host's SQLite, builds the same queries and messages as
// the library (structure_check.h). tests/db/schema_shape_test.cc checks
// this table against the tables that replaying the migrations makes, so it
// cannot drift from schema.cc.

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace hapticlab::db {

struct ColumnShape {
  const char* name;
  const char* type;  // INTEGER, REAL, TEXT or BLOB, as declared
  bool not_null;     // declared NOT NULL (an INTEGER PRIMARY KEY is never NULL either)
};

struct TableShape {
  const char* name;
  std::span<const ColumnShape> columns;
  int since_version;  // the schema version whose migration created it
};

// Every table of schema version kSchemaVersion (schema.h), by name.
std::span<const TableShape> schema_tables();
// The table called `name` (as SQLite compares names: ignoring ASCII case), or null.
const TableShape* find_schema_table(std::string_view name);

// A column as `PRAGMA table_info` describes it in a file.
struct FoundColumn {
  std::string name;
  std::string type;
  bool not_null = false;
};

// Why a file's object called table.name cannot be read as that table, or ""
// when it can: `kind` is its sqlite_master type ("table", "view", ...; empty
// when there is none), `columns` its columns in order (when a table).
// "table event is a view, not a table: it is refused before any query
// reads it", "table event has columns (...); expected (...)".
std::string shape_problem(const TableShape& table, std::string_view kind, const std::vector<FoundColumn>& columns);

// SQL for a row's trial: rowid in table trial, trial_id (when an integer)
// where the table has one, else NULL.
std::string trial_expression(const TableShape& table);

// SQL listing the rows of `table` (at most `limit`) with a value whose type
// is not its column's: INTEGER holds an integer, REAL a real, TEXT text,
// BLOB a blob, and NULL only where the column allows it. Result columns:
// rowid, the row's trial (its id for table trial, trial_id where there is
// one, else NULL), then for every column typeof(value) and the value as SQL
// text (quote(), cut to 40 characters). `where`, if not empty, is ANDed in
// (e.g. "trial_id = ?1"). Table and columns are qualified with `schema`.
std::string mistyped_rows_sql(const TableShape& table, std::string_view where = {}, std::size_t limit = 20,
                              std::string_view schema = "main");

// The message for one row of that query: "event row 17 of trial 3: t_s is
// text 'nan', expected a REAL" (every mistyped column of the row).
// `types` and `values` hold the query's typeof and quote columns in order.
std::string mistyped_row_message(const TableShape& table, std::int64_t rowid, std::optional<std::int64_t> trial,
                                 std::span<const std::string> types, std::span<const std::string> values);

// "event row 17 of trial 3", "trial 5", "participant row 2": how findings
// name a row.
std::string row_name(std::string_view table, std::int64_t rowid, std::optional<std::int64_t> trial);

// A row whose reference points at no row: "trial 5: participant_id 9
// refers to no participant row".
std::string broken_reference_message(std::string_view table, std::int64_t rowid, std::optional<std::int64_t> trial,
                                     std::string_view column, std::string_view value, std::string_view parent);

}  // namespace hapticlab::db
