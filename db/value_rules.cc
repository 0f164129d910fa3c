#include "db/value_rules.h"

#include <array>

#include "db/schema_shape.h"

namespace hapticlab::db {
namespace {

constexpr std::array<ValueRule, 7> kRules = {{
    {"study", "protocol_sha256", "length(protocol_sha256) = 64"},
    {"session", "clock", "clock IN ('virtual', 'wall')"},
    {"session", "status", "status IN ('open', 'closed', 'interrupted')"},
    {"trial", "status", "status IN ('planned', 'running', 'complete', 'aborted')"},
    {"sample_chunk", "instrument", "instrument IN (0, 1)", true},
    {"sample_chunk", "count", "count > 0", true},
    {"event", "instrument", "instrument IN (-1, 0, 1)"},
}};

}  // namespace

std::span<const ValueRule> schema_value_rules() { return kRules; }

std::string broken_rule_rows_sql(const ValueRule& rule, std::size_t limit, std::string_view schema) {
  // The names are the list's own (no quoting needed), the schema the caller's.
  const TableShape* shape = find_schema_table(rule.table);
  const std::string trial = shape != nullptr ? trial_expression(*shape) : std::string("NULL");
  return "SELECT rowid, " + trial + ", substr(quote(" + rule.column + "), 1, 40) FROM \"" + std::string(schema) +
         "\"." + rule.table + " WHERE " + rule.column + " IS NOT NULL AND NOT (" + rule.condition +
         ") ORDER BY rowid LIMIT " + std::to_string(limit);
}

std::string broken_rule_message(const ValueRule& rule, std::int64_t rowid, std::optional<std::int64_t> trial,
                                std::string_view value) {
  return row_name(rule.table, rowid, trial) + ": " + rule.column + " is " + std::string(value) +
         ", which breaks CHECK (" + rule.condition + ")";
}

}  // namespace hapticlab::db
