#pragma once
// `study check`'s whole examination of a study file: SQLite's
// integrity_check, then the structure (structure_check.h: tables,
// references, value types), then every sample chunk's place, checksum and
// structure (chunk_reader.h), each only when what it reads is sound.
#include <cstddef>
#include <string>
#include <vector>

#include "db/chunk_reader.h"
#include "db/sqlite_handle.h"
#include "db/structure_check.h"

namespace hapticlab::db {

// Every finding in the order checked.
struct StudyFileCheck {
  std::vector<Finding> findings;
  std::size_t integrity = 0;  // integrity_check's findings
  std::size_t structure = 0;  // tables, references, value types
  ChunkCheck chunks;
  std::string not_checked;    // why the chunks were not checked; empty if they were
  bool damaged() const { return !findings.empty() || !not_checked.empty(); }
};

// On a plain (read-only) connection, not StudyDb: StudyDb refuses a damaged
// file at the door, and this check's job is to say everything that is
// damaged. The structure is checked only at a known schema version and the
// chunks only when the tables are the schema's (a view in a table's place
// could make any query hang) and the version is the current one (an older
// file has other checksums): otherwise not_checked says why. Never throws
// for damage; each finding names what it concerns.
StudyFileCheck check_study_file(Database& conn);

}  // namespace hapticlab::db
