#pragma once
// The CHECK constraints of the current schema (schema.cc), as data, and the
// SQL and message of the check built on them. SQLite verifies CHECK
// constraints when a row is written, but not in integrity_check on a
// read-only connection, which is how every reader opens a file: a file
// edited with `PRAGMA ignore_check_constraints` (trial status 'done', an
// event of instrument 5, a session clock 'bogus') passed `study check`, and
// analyze read it. tests/db/value_rules_test.cc checks this list against
// the CHECKs of the schema that replaying the migrations makes.
//
// Pure text, like schema_shape.h.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace hapticlab::db {

struct ValueRule {
  const char* table;
  const char* column;
  const char* condition;  // the CHECK's expression, as schema.cc writes it
  // sample_chunk's rules are checked chunk by chunk (chunk_layout.h): a bad
  // chunk leaves out its trial, not the whole file, so the structure check
  // skips them.
  bool checked_per_chunk = false;
};

// Every CHECK of schema version kSchemaVersion.
std::span<const ValueRule> schema_value_rules();

// SQL listing the rows of `rule.table` (at most `limit`) whose value breaks
// the rule (NULLs pass, as they pass a CHECK). Result columns: rowid, the
// row's trial (as mistyped_rows_sql), the value as SQL text (quote(), cut
// to 40 characters).
std::string broken_rule_rows_sql(const ValueRule& rule, std::size_t limit = 20, std::string_view schema = "main");

// "trial 3: status is 'done', which breaks CHECK (status IN ('planned', ...))".
std::string broken_rule_message(const ValueRule& rule, std::int64_t rowid, std::optional<std::int64_t> trial,
                                std::string_view value);

}  // namespace hapticlab::db
