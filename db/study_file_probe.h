#pragma once
// Whether a file holds a HapticLab study, found without changing the file:
// opened read-only, never created, migrated or recovered. For a command that
// would otherwise change the file before finding out it is no study (the
// console opens it read-write, which makes an empty file an SQLite database,
// and writes its token file beside it).

#include <filesystem>

namespace hapticlab::db {

// Throws DbError naming the file: a missing file or one that is not a
// regular file; an empty one ("the file is empty: it holds no study"); a
// file that is not SQLite, not HapticLab's or of a newer schema (as StudyDb
// says it); a HapticLab file without a study. A study of an older schema
// passes: opening it read-write migrates it.
void refuse_unless_study(const std::filesystem::path& path);

}  // namespace hapticlab::db
