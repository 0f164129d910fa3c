#include "db/schema_shape.h"

#include <array>
#include <cctype>

namespace hapticlab::db {
namespace {

// Schema version 11 (schema.cc), as PRAGMA table_info reports it after the
// migrations. Order of columns as in the file.
constexpr ColumnShape kStudy[] = {{"id", "INTEGER", false},           {"name", "TEXT", true},
                                  {"protocol_json", "TEXT", true},    {"protocol_sha256", "TEXT", true},
                                  {"seed", "TEXT", true},             {"software_version", "TEXT", true},
                                  {"created_utc", "TEXT", true}};
constexpr ColumnShape kParticipant[] = {{"id", "INTEGER", false}, {"study_id", "INTEGER", true}, {"code", "TEXT", true}};
constexpr ColumnShape kSetting[] = {{"id", "INTEGER", false},
                                    {"study_id", "INTEGER", true},
                                    {"name", "TEXT", true},
                                    {"parameters_json", "TEXT", true},
                                    {"parameters_sha256", "TEXT", true}};
constexpr ColumnShape kSession[] = {{"id", "INTEGER", false},       {"participant_id", "INTEGER", true},
                                    {"started_unix_s", "REAL", true}, {"ended_unix_s", "REAL", false},
                                    {"device", "TEXT", true},       {"clock", "TEXT", true},
                                    {"status", "TEXT", true},       {"site", "TEXT", false},
                                    {"rate_Hz", "REAL", false},     {"participant_model", "TEXT", false}};
constexpr ColumnShape kTrial[] = {{"id", "INTEGER", false},        {"participant_id", "INTEGER", true},
                                  {"task", "TEXT", true},          {"setting_id", "INTEGER", true},
                                  {"repetition", "INTEGER", true}, {"block", "INTEGER", true},
                                  {"position", "INTEGER", true},   {"status", "TEXT", true},
                                  {"session_id", "INTEGER", false}, {"started_unix_s", "REAL", false},
                                  {"ended_unix_s", "REAL", false}, {"abort_reason", "TEXT", false}};
constexpr ColumnShape kSampleChunk[] = {{"id", "INTEGER", false},        {"trial_id", "INTEGER", true},
                                        {"instrument", "INTEGER", true}, {"first_tick", "INTEGER", true},
                                        {"count", "INTEGER", true},      {"t0_s", "REAL", true},
                                        {"data", "BLOB", true}};
constexpr ColumnShape kEvent[] = {{"id", "INTEGER", false},        {"trial_id", "INTEGER", true},
                                  {"t_s", "REAL", true},           {"type", "TEXT", true},
                                  {"instrument", "INTEGER", true}, {"item_index", "INTEGER", true},
                                  {"detail", "TEXT", false}};
constexpr ColumnShape kTraining[] = {{"id", "INTEGER", false},         {"session_id", "INTEGER", true},
                                     {"task", "TEXT", true},           {"started_unix_s", "REAL", true},
                                     {"ended_unix_s", "REAL", false},  {"duration_s", "REAL", false},
                                     {"trials", "INTEGER", true},      {"cut_short", "INTEGER", true},
                                     {"cut_short_reason", "TEXT", false}};
constexpr ColumnShape kLoopTiming[] = {{"trial_id", "INTEGER", false},        {"count", "INTEGER", false},
                                       {"p50_period_s", "REAL", false},       {"p99_period_s", "REAL", false},
                                       {"max_period_s", "REAL", false},       {"mean_period_s", "REAL", false},
                                       {"overruns", "INTEGER", false},        {"rejected_periods", "INTEGER", false},
                                       {"dropped_samples", "INTEGER", true},  {"dropped_events", "INTEGER", true}};
constexpr ColumnShape kDeviceCounter[] = {{"trial_id", "INTEGER", true}, {"name", "TEXT", true}, {"value", "INTEGER", true}};
constexpr ColumnShape kOperatorAction[] = {{"id", "INTEGER", false},    {"session_id", "INTEGER", false},
                                           {"trial_id", "INTEGER", false}, {"unix_s", "REAL", true},
                                           {"t_s", "REAL", false},      {"type", "TEXT", true},
                                           {"detail", "TEXT", true}};

constexpr std::array<TableShape, 11> kTables = {{
    {"study", kStudy, 1},
    {"participant", kParticipant, 1},
    {"setting", kSetting, 1},
    {"session", kSession, 1},
    {"training", kTraining, 2},
    {"trial", kTrial, 1},
    {"sample_chunk", kSampleChunk, 1},
    {"event", kEvent, 1},
    {"loop_timing", kLoopTiming, 2},
    {"device_counter", kDeviceCounter, 5},
    {"operator_action", kOperatorAction, 6},
}};

bool same_name(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(a[i])) != std::tolower(static_cast<unsigned char>(b[i]))) return false;
  return true;
}

std::string describe_columns(std::span<const ColumnShape> columns) {
  std::string out;
  for (const ColumnShape& c : columns)
    out += (out.empty() ? "" : ", ") + std::string(c.name) + " " + c.type + (c.not_null ? " NOT NULL" : "");
  return out;
}

std::string describe_columns(const std::vector<FoundColumn>& columns) {
  std::string out;
  for (const FoundColumn& c : columns)
    out += (out.empty() ? "" : ", ") + c.name + " " + (c.type.empty() ? "(no type)" : c.type) +
           (c.not_null ? " NOT NULL" : "");
  return out;
}

// "x" as an SQL identifier.
std::string sql_name(std::string_view name) {
  std::string out = "\"";
  for (char c : name) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

// typeof() values a column's values may have.
std::string allowed_types(const ColumnShape& c) {
  const std::string_view t = c.type;
  const char* type = t == "INTEGER" ? "integer" : t == "REAL" ? "real" : t == "TEXT" ? "text" : "blob";
  return std::string("'") + type + "'" + (c.not_null ? "" : ", 'null'");
}

bool allowed(const ColumnShape& c, std::string_view type_of) {
  if (type_of == "null") return !c.not_null;
  const std::string_view t = c.type;
  return (t == "INTEGER" && type_of == "integer") || (t == "REAL" && type_of == "real") ||
         (t == "TEXT" && type_of == "text") || (t == "BLOB" && type_of == "blob");
}


}  // namespace

std::span<const TableShape> schema_tables() { return kTables; }

std::string trial_expression(const TableShape& table) {
  if (same_name(table.name, "trial")) return "rowid";
  for (const ColumnShape& c : table.columns)
    if (same_name(c.name, "trial_id")) return "CASE typeof(trial_id) WHEN 'integer' THEN trial_id END";
  return "NULL";
}

const TableShape* find_schema_table(std::string_view name) {
  for (const TableShape& t : kTables)
    if (same_name(t.name, name)) return &t;
  return nullptr;
}

std::string shape_problem(const TableShape& table, std::string_view kind, const std::vector<FoundColumn>& columns) {
  const std::string name = table.name;
  if (kind.empty()) return "table " + name + " is missing";
  if (kind != "table")
    return "table " + name + " is a " + std::string(kind) +
           ", not a table: it is refused before any query reads it (a view can hold anything, or never end)";
  bool same = columns.size() == table.columns.size();
  for (std::size_t i = 0; same && i < columns.size(); ++i) {
    const ColumnShape& want = table.columns[i];
    same = same_name(columns[i].name, want.name) && same_name(columns[i].type, want.type) &&
           (columns[i].not_null == want.not_null);
  }
  if (same) return {};
  return "table " + name + " has columns (" + describe_columns(columns) + "); expected (" +
         describe_columns(table.columns) + ")";
}

std::string mistyped_rows_sql(const TableShape& table, std::string_view where, std::size_t limit,
                              std::string_view schema) {
  std::string select = "SELECT rowid, " + trial_expression(table);
  std::string bad;
  for (const ColumnShape& c : table.columns) {
    const std::string col = sql_name(c.name);
    select += ", typeof(" + col + "), substr(quote(" + col + "), 1, 40)";
    bad += (bad.empty() ? "" : " OR ") + ("typeof(" + col + ") NOT IN (" + allowed_types(c) + ")");
  }
  std::string sql = select + " FROM " + sql_name(schema) + "." + sql_name(table.name) + " WHERE ";
  if (!where.empty()) sql += "(" + std::string(where) + ") AND ";
  return sql + "(" + bad + ") ORDER BY rowid LIMIT " + std::to_string(limit);
}

std::string row_name(std::string_view table, std::int64_t rowid, std::optional<std::int64_t> trial) {
  if (same_name(table, "trial")) return "trial " + std::to_string(rowid);
  std::string out = std::string(table) + " row " + std::to_string(rowid);
  if (trial) out += " of trial " + std::to_string(*trial);
  return out;
}

std::string mistyped_row_message(const TableShape& table, std::int64_t rowid, std::optional<std::int64_t> trial,
                                 std::span<const std::string> types, std::span<const std::string> values) {
  std::string what;
  for (std::size_t c = 0; c < table.columns.size() && c < types.size(); ++c) {
    const ColumnShape& col = table.columns[c];
    if (allowed(col, types[c])) continue;
    what += (what.empty() ? "" : "; ") + std::string(col.name) + " is " + types[c] +
            (types[c] == "null" ? "" : " " + (c < values.size() ? values[c] : std::string("?"))) + ", expected " +
            (std::string_view(col.type) == "INTEGER" ? "an " : "a ") + col.type + (col.not_null ? "" : " or NULL");
  }
  return row_name(table.name, rowid, trial) + ": " + what;
}

std::string broken_reference_message(std::string_view table, std::int64_t rowid, std::optional<std::int64_t> trial,
                                     std::string_view column, std::string_view value, std::string_view parent) {
  return row_name(table, rowid, trial) + ": " + std::string(column) + " " + std::string(value) + " refers to no " +
         std::string(parent) + " row";
}

}  // namespace hapticlab::db
