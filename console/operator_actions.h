#pragma once
// The console operator's actions, stored in the study database (table
// operator_action, db/README.md) when the console accepts them, before it
// answers: a note, a pause, a rest, "next", "end training", an abort and
// STOP are in the file the moment the page hears "200", whether a trial
// runs or not, and whatever happens to the console afterwards (kill -9).

#include <filesystem>
#include <mutex>

#include "db/study_db.h"

namespace hapticlab::console {

class OperatorActions {
 public:
  // Opens the database read-write (migrating it to the current schema),
  // without recovery: a session of another process may be running.
  // Throws db::DbError naming the file.
  explicit OperatorActions(const std::filesystem::path& db);

  // Stores `action` (its unix_s stamped now unless set) and commits; throws
  // db::DbError naming what failed. Thread-safe.
  void record(db::OperatorActionRow action);

 private:
  std::mutex mutex_;
  db::StudyDb db_;
};

}  // namespace hapticlab::console
