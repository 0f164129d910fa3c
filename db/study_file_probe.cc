#include "db/study_file_probe.h"

#include <string>
#include <system_error>

#include "db/schema.h"
#include "db/sqlite_handle.h"
#include "db/study_db.h"

namespace hapticlab::db {

void refuse_unless_study(const std::filesystem::path& path) {
  namespace fs = std::filesystem;
  const std::string name = path.string();
  const std::string no_study = "it holds no study (run `hapticlab study create` first)";
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (!fs::exists(status)) throw DbError(name + ": no such file");
  if (!fs::is_regular_file(status)) throw DbError(name + ": is not a regular file; expected a study database");
  // SQLite would take an empty file for a new database; a read-only
  // connection would not write it, but nothing could be read from it either.
  if (fs::file_size(path, ec) == 0 && !ec) throw DbError(name + ": the file is empty: " + no_study);
  Database db(path, Database::Mode::kReadOnly);
  refuse_non_sqlite_file(db);
  // Throws for a file that is not HapticLab's or is newer than this build.
  if (check_schema_version(db) == 0) throw DbError(name + ": an SQLite database without HapticLab's tables: " + no_study);
  Statement count = db.prepare("SELECT count(*) FROM study");
  if (!count.step() || count.column_int64(0) == 0) throw DbError(name + ": " + no_study);
}

}  // namespace hapticlab::db
