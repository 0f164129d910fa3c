#pragma once
// The study database's schema: its version, the DDL and the migrations
// that bring an older file up to date. Tables and columns: db/README.md.
//
// The version lives in the file header (PRAGMA user_version) next to an
// application id ("HLAB", PRAGMA application_id), so a file from another
// program is refused instead of being written to. A database is only ever
// built by replaying the migrations in order, from version 0 (empty) to
// kSchemaVersion: a fresh file and a migrated old file run the same SQL and
// cannot drift apart.

#include <cstdint>
#include <span>

#include "db/sqlite_handle.h"

namespace hapticlab::db {

inline constexpr int kSchemaVersion = 11;
inline constexpr std::int32_t kApplicationId = 0x484C4142;  // "HLAB"

struct Migration {
  int to_version;           // this step takes version to_version - 1 to to_version
  const char* description;  // one line, for messages and db/README.md
  const char* sql;          // run inside the migration transaction
  // Run after `sql`, in the same transaction, for what SQL cannot do
  // (versions 4 and 7 rewrite every chunk's checksum); may be null.
  void (*convert)(Database& db) = nullptr;
};

// Every step, in order; migrations()[i].to_version == i + 1.
std::span<const Migration> migrations();

// Brings `db` to kSchemaVersion in one transaction (all steps or none) and
// returns the version it found. Throws DbError, naming the file, when the
// file is newer than kSchemaVersion, is not a HapticLab database, or a step
// fails (the file is then left exactly as it was).
int migrate(Database& db);

// The version of an open database without changing it; throws DbError like
// migrate() for a file that is not ours or is newer than we support.
int check_schema_version(Database& db);

}  // namespace hapticlab::db
