#include "db/study_digests.h"

#include <string>

namespace hapticlab::db {
namespace {

Finding edited(std::string table, std::int64_t row, std::string message) {
  Finding f;
  f.check = "edited";
  f.table = std::move(table);
  f.row = row;
  f.message = std::move(message);
  return f;
}

}  // namespace

std::vector<Finding> check_digests(Database& db, std::size_t limit) {
  std::vector<Finding> out;
  {
    // typeof: a value of another type is check_value_types' finding.
    Statement s = db.prepare(
        "SELECT id, protocol_json, protocol_sha256 FROM main.study "
        "WHERE typeof(protocol_json) = 'text' AND typeof(protocol_sha256) = 'text' ORDER BY id");
    while (s.step() && out.size() < limit)
      if (const std::string found = text_digest(s.column_text(1)); found != s.column_text(2))
        out.push_back(edited("study", s.column_int64(0),
                             edited_protocol_message(s.column_int64(0), s.column_text(2), found)));
  }
  Statement s = db.prepare(
      "SELECT id, name, parameters_json, parameters_sha256 FROM main.setting "
      "WHERE typeof(parameters_json) = 'text' AND typeof(parameters_sha256) = 'text' ORDER BY id");
  while (s.step() && out.size() < limit)
    if (const std::string found = text_digest(s.column_text(2)); found != s.column_text(3))
      out.push_back(edited("setting", s.column_int64(0),
                           edited_setting_message(s.column_int64(0), s.column_text(1), s.column_text(3), found)));
  return out;
}

}  // namespace hapticlab::db
