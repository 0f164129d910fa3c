#include "db/study_check.h"

#include <optional>

#include "db/schema.h"
#include "db/study_digests.h"

namespace hapticlab::db {
namespace {

void check_integrity(Database& conn, StudyFileCheck& c) {
  try {
    Statement s = conn.prepare("PRAGMA integrity_check(100)");
    while (s.step())
      if (const std::string line = s.column_text(0); line != "ok") {
        c.findings.push_back({"integrity", "", std::nullopt, std::nullopt, std::nullopt, line});
        ++c.integrity;
      }
  } catch (const DbError& e) {
    // Not a finding about the file when it cannot be read here at all.
    if (!e.is_damage()) throw DbError(unreadable_reason(conn.path(), e), e.sqlite_code());
    c.findings.push_back({"integrity", "", std::nullopt, std::nullopt, std::nullopt,
                          std::string("integrity_check itself failed: ") + e.what()});
    ++c.integrity;
  }
}

void check_structure_and_chunks(Database& conn, StudyFileCheck& c) {
  try {
    const int version = check_schema_version(conn);
    std::vector<Finding> tables = check_tables(conn, version);
    c.structure += tables.size();
    c.findings.insert(c.findings.end(), tables.begin(), tables.end());
    if (!tables.empty()) {
      c.not_checked = "the tables are not what the schema says (above), so no query reads them";
    } else if (version < kSchemaVersion) {
      c.not_checked = "schema version " + std::to_string(version) + " predates this HapticLab's checks (version " +
                      std::to_string(kSchemaVersion) + "); a command that opens it read-write "
                      "(`hapticlab analyze`) migrates it, then check again";
    } else {
      const auto add = [&c](const std::vector<Finding>& found) {
        c.structure += found.size();
        c.findings.insert(c.findings.end(), found.begin(), found.end());
      };
      add(check_foreign_keys(conn, std::size_t{100}));  // (schema.cc has a check_foreign_keys of its own)
      add(check_value_types(conn, std::size_t{100}));
      add(check_digests(conn, std::size_t{100}));
      c.chunks = check_all_chunks(conn);
      for (const BadChunk& b : c.chunks.bad)
        c.findings.push_back({"chunk", "sample_chunk", std::nullopt, b.trial_id, b.instrument, describe(b)});
    }
  } catch (const DbError& e) {
    c.not_checked = e.what();
  }
}

}  // namespace

StudyFileCheck check_study_file(Database& conn) {
  StudyFileCheck c;
  check_integrity(conn, c);
  check_structure_and_chunks(conn, c);
  return c;
}

}  // namespace hapticlab::db
