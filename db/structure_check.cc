#include "db/structure_check.h"

#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "db/schema.h"
#include "db/schema_shape.h"
#include "db/value_rules.h"

namespace hapticlab::db {
namespace {

Finding finding(const char* check, std::string table, std::optional<std::int64_t> row,
                std::optional<std::int64_t> trial, std::string message) {
  Finding f;
  f.check = check;
  f.table = std::move(table);
  f.row = row;
  f.trial_id = trial;
  f.message = std::move(message);
  return f;
}

std::optional<std::int64_t> opt_int(const Statement& s, int c) {
  if (s.is_null(c)) return std::nullopt;
  return s.column_int64(c);
}

// "x" as an SQL identifier.
std::string sql_name(const std::string& name) {
  std::string out = "\"";
  for (char c : name) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

// The tasks a study's protocol names ("tasks": an array of strings), or
// none when its text does not say (then nothing is compared).
std::optional<std::set<std::string>> protocol_tasks(const std::string& protocol_json) {
  const nlohmann::json p = nlohmann::json::parse(protocol_json, nullptr, false);
  if (p.is_discarded() || !p.is_object() || !p.contains("tasks") || !p["tasks"].is_array()) return std::nullopt;
  std::set<std::string> out;
  for (const nlohmann::json& t : p["tasks"]) {
    if (!t.is_string()) return std::nullopt;
    out.insert(t.get<std::string>());
  }
  return out;
}

// Trials and training of a task their study's protocol does not name: a
// trial edited to task 'foo' was analysed as a third task, and moved out of
// its own task's comparisons.
void add_tasks_outside_the_protocol(Database& db, std::size_t limit, std::vector<Finding>& out) {
  Statement studies = db.prepare("SELECT id, protocol_json FROM main.study WHERE typeof(protocol_json) = 'text'");
  while (studies.step()) {
    const std::optional<std::set<std::string>> tasks = protocol_tasks(studies.column_text(1));
    if (!tasks) continue;
    std::string named;
    for (const std::string& t : *tasks) named += (named.empty() ? "" : ", ") + t;
    Statement rows = db.prepare(
        "SELECT 'trial', t.id, t.id, t.task FROM main.trial t JOIN main.participant p ON p.id = t.participant_id "
        "WHERE p.study_id = ?1 UNION ALL SELECT 'training', r.id, NULL, r.task FROM main.training r JOIN "
        "main.session s ON s.id = r.session_id JOIN main.participant p ON p.id = s.participant_id "
        "WHERE p.study_id = ?1");
    rows.bind(1, studies.column_int64(0));
    while (out.size() < limit && rows.step()) {
      if (tasks->contains(rows.column_text(3))) continue;
      const std::string table = rows.column_text(0);
      out.push_back(finding("foreign_key", table, rows.column_int64(1), opt_int(rows, 2),
                            row_name(table, rows.column_int64(1), opt_int(rows, 2)) + ": task '" +
                                rows.column_text(3) + "' is not one of its study's protocol's tasks (" + named + ")"));
    }
  }
}

// What a trial's status says against what it holds. A trial starts
// (planned => running) with its session and start time, and ends with its
// end time; a planned one has run in no session, so samples or events of it
// were read by nobody (export and analyze take the trials that ran), and a
// trial that ran but names no session or start time was read as done with
// nothing to show.
void add_status_misfits(Database& db, std::size_t limit, std::vector<Finding>& out) {
  Statement q = db.prepare(
      "SELECT t.id, t.status, quote(t.session_id), quote(t.started_unix_s), quote(t.ended_unix_s), "
      "(SELECT count(*) FROM main.sample_chunk c WHERE c.trial_id = t.id), "
      "(SELECT count(*) FROM main.event e WHERE e.trial_id = t.id) FROM main.trial t "
      "WHERE (t.status = 'planned' AND (t.session_id IS NOT NULL OR t.started_unix_s IS NOT NULL OR "
      "t.ended_unix_s IS NOT NULL OR EXISTS (SELECT 1 FROM main.sample_chunk c WHERE c.trial_id = t.id) OR "
      "EXISTS (SELECT 1 FROM main.event e WHERE e.trial_id = t.id))) OR "
      "(t.status IN ('running', 'complete', 'aborted') AND (t.session_id IS NULL OR t.started_unix_s IS NULL)) OR "
      "(t.status = 'complete' AND t.ended_unix_s IS NULL) ORDER BY t.id");
  while (out.size() < limit && q.step()) {
    const std::int64_t id = q.column_int64(0);
    const std::string status = q.column_text(1);
    std::string held;
    const auto also = [&held](const std::string& part) { held += (held.empty() ? "" : ", ") + part; };
    if (status == "planned") {
      if (q.column_text(2) != "NULL") also("session_id " + q.column_text(2));
      if (q.column_text(3) != "NULL") also("started_unix_s " + q.column_text(3));
      if (q.column_text(4) != "NULL") also("ended_unix_s " + q.column_text(4));
      if (q.column_int64(5) > 0) also(std::to_string(q.column_int64(5)) + " sample chunk(s)");
      if (q.column_int64(6) > 0) also(std::to_string(q.column_int64(6)) + " event(s)");
      held = "status is 'planned', but it has " + held +
             " (a planned trial has not run: what it holds is read by no export or analysis)";
    } else {
      if (q.column_text(2) == "NULL") also("session_id");
      if (q.column_text(3) == "NULL") also("started_unix_s");
      if (status == "complete" && q.column_text(4) == "NULL") also("ended_unix_s");
      held = "status is '" + status + "', but " + held + (held.find(',') == std::string::npos ? " is" : " are") +
             " NULL (a trial gets its session and start time when it starts, and a complete one its end time)";
    }
    out.push_back(finding("foreign_key", "trial", id, id, row_name("trial", id, id) + ": " + held));
  }
}

// References to rows that exist but do not fit (foreign_key_check passes
// them): a trial run in another participant's session (every reader took
// it; a merge dropped it without a word), a trial still running in a
// session that has ended (sessions end after their trials, a dead one's
// recovery ends both; readers counted it as not run, samples and all), a
// task the protocol does not name, an action on a trial of another session.
void add_misfit_references(Database& db, std::size_t limit, std::vector<Finding>& out) {
  // Each query's columns: the row's id, its trial, then what its message names.
  const auto add = [&](const char* table, const std::string& sql, auto message) {
    Statement q = db.prepare(sql);
    while (out.size() < limit && q.step())
      out.push_back(finding("foreign_key", table, q.column_int64(0), opt_int(q, 1),
                            row_name(table, q.column_int64(0), opt_int(q, 1)) + ": " + message(q)));
  };
  add("trial",
      "SELECT t.id, t.id, t.session_id, q.code, p.code FROM main.trial t JOIN main.session s ON s.id = t.session_id "
      "JOIN main.participant p ON p.id = t.participant_id JOIN main.participant q ON q.id = s.participant_id "
      "WHERE s.participant_id <> t.participant_id ORDER BY t.id",
      [](const Statement& q) {
        return "session_id " + std::to_string(q.column_int64(2)) + " is participant '" + q.column_text(3) +
               "''s session, but the trial is participant '" + q.column_text(4) + "''s";
      });
  add("trial",
      "SELECT t.id, t.id, s.id, s.status FROM main.trial t JOIN main.session s ON s.id = t.session_id "
      "WHERE t.status = 'running' AND s.status <> 'open' ORDER BY t.id",
      [](const Statement& q) {
        return "status is 'running', but its session " + std::to_string(q.column_int64(2)) + " is " +
               q.column_text(3) + " (a session ends after its trials)";
      });
  add_tasks_outside_the_protocol(db, limit, out);
  add_status_misfits(db, limit, out);
  add("operator_action",
      "SELECT a.id, a.trial_id, a.session_id, t.session_id FROM main.operator_action a JOIN main.trial t ON "
      "t.id = a.trial_id WHERE a.session_id IS NOT NULL AND t.session_id IS NOT NULL AND a.session_id <> t.session_id "
      "ORDER BY a.id",
      [](const Statement& q) {
        return "session_id " + std::to_string(q.column_int64(2)) + ", but its trial ran in session " +
               std::to_string(q.column_int64(3));
      });
}

}  // namespace

std::vector<Finding> check_tables(Database& db, int version) {
  std::vector<Finding> out;
  Statement kind = db.prepare(
      "SELECT type FROM main.sqlite_schema WHERE name = ?1 COLLATE NOCASE AND type IN ('table', 'view') LIMIT 1");
  Statement columns = db.prepare("SELECT name, type, \"notnull\" FROM pragma_table_info(?1, 'main') ORDER BY cid");
  for (const TableShape& table : schema_tables()) {
    if (table.since_version > version) continue;
    kind.reset();
    kind.bind(1, table.name);
    const std::string type = kind.step() ? kind.column_text(0) : std::string();
    std::vector<FoundColumn> found;
    if (type == "table") {
      columns.reset();
      columns.bind(1, table.name);
      while (columns.step()) found.push_back({columns.column_text(0), columns.column_text(1), columns.column_int64(2) != 0});
    }
    std::string problem = shape_problem(table, type, found);
    // Older schemas had other columns (the migrations change them), and a
    // table missing there fails its migration, naming the step: only that
    // what is there is a table is checked, before any migration reads it.
    const bool current = version == kSchemaVersion;
    if (!problem.empty() && (current || (!type.empty() && type != "table")))
      out.push_back(finding("schema", table.name, std::nullopt, std::nullopt, std::move(problem)));
  }
  return out;
}

std::vector<Finding> check_foreign_keys(Database& db, std::size_t limit) {
  std::vector<Finding> out;
  Statement check = db.prepare("PRAGMA main.foreign_key_check");
  while (out.size() < limit && check.step()) {
    const std::string table = check.column_text(0);
    const std::optional<std::int64_t> rowid = opt_int(check, 1);
    const std::string parent = check.column_text(2);
    const std::int64_t fk = check.column_int64(3);
    std::string column = "?";
    {
      Statement from = db.prepare("SELECT \"from\" FROM pragma_foreign_key_list(?1, 'main') WHERE id = ?2 LIMIT 1");
      from.bind(1, table).bind(2, fk);
      if (from.step()) column = from.column_text(0);
    }
    std::string value = "?";
    std::optional<std::int64_t> trial;
    if (rowid) {
      const TableShape* shape = find_schema_table(table);
      bool has_trial = false;
      if (shape != nullptr)
        for (const ColumnShape& c : shape->columns) has_trial = has_trial || std::string(c.name) == "trial_id";
      Statement row = db.prepare("SELECT quote(" + sql_name(column) + "), " + (has_trial ? "trial_id" : "NULL") +
                                 " FROM main." + sql_name(table) + " WHERE rowid = ?1");
      row.bind(1, *rowid);
      if (row.step()) {
        value = row.column_text(0);
        if (shape != nullptr && std::string(shape->name) == "trial") trial = *rowid;
        else if (!row.is_null(1)) trial = row.column_int64(1);
      }
    }
    out.push_back(finding("foreign_key", table, rowid, trial,
                          broken_reference_message(table, rowid.value_or(0), trial, column, value, parent)));
  }
  add_misfit_references(db, limit, out);
  return out;
}

std::vector<Finding> check_value_types(Database& db, std::size_t limit, int version) {
  std::vector<Finding> out;
  Statement has_column = db.prepare("SELECT count(*) FROM pragma_table_info(?1, 'main') WHERE name = ?2");
  const auto exists = [&](const char* table, const char* column) {
    has_column.reset();
    has_column.bind(1, table).bind(2, column);
    return has_column.step() && has_column.column_int64(0) > 0;
  };
  for (const TableShape& current : schema_tables()) {
    if (current.since_version > version) continue;
    // The columns the file has (all of them at the current version).
    std::vector<ColumnShape> columns;
    for (const ColumnShape& c : current.columns)
      if (version == kSchemaVersion || exists(current.name, c.name)) columns.push_back(c);
    const TableShape table{current.name, columns, current.since_version};
    Statement s = db.prepare(mistyped_rows_sql(table, {}, limit));
    std::vector<std::string> types(table.columns.size()), values(table.columns.size());
    while (s.step()) {
      const std::int64_t rowid = s.column_int64(0);
      const std::optional<std::int64_t> trial = opt_int(s, 1);
      for (std::size_t c = 0; c < table.columns.size(); ++c) {
        types[c] = s.column_text(static_cast<int>(2 + 2 * c));
        values[c] = s.column_text(static_cast<int>(3 + 2 * c));
      }
      out.push_back(finding("type", table.name, rowid, trial, mistyped_row_message(table, rowid, trial, types, values)));
    }
  }
  for (const ValueRule& rule : schema_value_rules()) {
    if (rule.checked_per_chunk || (version != kSchemaVersion && !exists(rule.table, rule.column))) continue;
    Statement s = db.prepare(broken_rule_rows_sql(rule, limit));
    while (s.step())
      out.push_back(finding("type", rule.table, s.column_int64(0), opt_int(s, 1),
                            broken_rule_message(rule, s.column_int64(0), opt_int(s, 1), s.column_text(2))));
  }
  return out;
}

void refuse_findings(const Database& db, const std::vector<Finding>& findings) {
  if (findings.empty()) return;
  constexpr std::size_t kShown = 5;
  std::string list;
  for (std::size_t i = 0; i < findings.size() && i < kShown; ++i) list += "; " + findings[i].message;
  if (findings.size() > kShown) list += "; ... (`hapticlab study check` lists them all)";
  throw DbError(db.path() + ": the file's structure is damaged, " + std::to_string(findings.size()) +
                " finding(s)" + list);
}

}  // namespace hapticlab::db
