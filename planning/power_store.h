#pragma once
// The finished studies of a `plan power` run, in a SQLite file in its
// output folder (plan_power.db), so an interrupted run resumes where it
// stopped: each study is committed in one transaction when it finishes,
// and a run asked with other inputs (protocol, seed, options) is refused
// rather than mixed with the stored one. A study's findings, staircases and
// changes against the control (study_change.h) and trials run and timed out
// per setting are stored with it.
#include <filesystem>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "db/sqlite_handle.h"
#include "planning/power.h"

namespace hapticlab::planning {

class PowerStore {
 public:
  // Opens or creates `path`. `inputs` describes what determines the
  // results (protocol hash, seed, rate, time limit, analysis options); a
  // file made with other inputs is refused (std::runtime_error naming both).
  PowerStore(const std::filesystem::path& path, const std::string& inputs);

  // Studies already stored: (participants, index).
  std::set<std::pair<int, int>> done();
  std::vector<StudyOutcome> load();
  // Throws db::DbError (a full disk, say) with nothing half-written.
  void add(const StudyOutcome& outcome);

 private:
  db::Database db_;
};

}  // namespace hapticlab::planning
