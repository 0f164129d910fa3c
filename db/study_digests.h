#pragma once
// Finds every protocol text and setting that no longer matches its digest
// (study_digest_rules.h says why they are kept and what they prove).

#include <cstddef>
#include <vector>

#include "db/sqlite_handle.h"
#include "db/structure_check.h"
#include "db/study_digest_rules.h"

namespace hapticlab::db {

// Every study's protocol and every setting whose text does not match its
// digest, as findings of check "edited"; at most `limit`. Needs the
// current schema (check_tables passed).
std::vector<Finding> check_digests(Database& db, std::size_t limit = 100);

}  // namespace hapticlab::db
