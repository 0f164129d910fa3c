#pragma once
// The finished studies of a `plan power` run, in a SQLite file in its
// output folder (plan_power.db), so an interrupted run resumes where it
// stopped: each study is committed in one transaction when it finishes,
// with its findings, staircases, changes against the control
// (study_change.h) and trials run and timed out per setting.
//
// The file proves what it holds before anything in it is used:
//   - it records the plan's inputs (plan_inputs.h); a run with other
//     inputs is refused, naming what changed, never mixed with it;
//   - every row is checked against the plan: its columns' types and
//     ranges, that it belongs to a study of the plan (a participant count
//     and study number the plan asks for, no finding or staircase row
//     without its study), that no test appears twice in a study;
//   - what can be recomputed is, and must agree: a study's seed (from the
//     plan's seed), whether each test is significant (from its p, alpha,
//     the Šidák level and, for the thesis' procedure, the study's own
//     Table 3.4 tests), and a SHA-256 of each study's rows under the plan's
//     inputs, which an edited finding no longer matches;
//   - after a run, the set of studies must be the plan's, complete.
// Any row that fails is refused (PlanStoreError), naming the file, the row
// and the reason.
#include <filesystem>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "db/sqlite_handle.h"
#include "planning/plan_inputs.h"
#include "planning/power.h"
#include "protocols/protocol.h"

namespace hapticlab::planning {

// A plan_power.db that is not the plan asked for, or whose rows fail a check.
class PlanStoreError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class PowerStore {
 public:
  // Opens or creates `path` for the plan `inputs` of `protocol` (the one
  // the inputs were made from), and checks every stored row (load()).
  // Throws PlanStoreError for a file of another plan, an older format, or
  // a row that fails; db::DbError for what SQLite cannot read.
  PowerStore(const std::filesystem::path& path, const PlanInputs& inputs, const protocols::Protocol& protocol);
  ~PowerStore();
  PowerStore(const PowerStore&) = delete;
  PowerStore& operator=(const PowerStore&) = delete;

  // Studies already stored: (participants, index).
  std::set<std::pair<int, int>> done();
  // Every stored study, checked as above; `complete`: also refuses a plan
  // missing any of its studies.
  std::vector<StudyOutcome> load(bool complete = false);
  // Throws db::DbError (a full disk, say) with nothing half-written.
  void add(const StudyOutcome& outcome);

  // The plan recorded in an existing plan_power.db, read-only, after
  // SQLite's check of the file (PlanStoreError when it holds none or is
  // damaged): what `plan merge` compares its shards by.
  static PlanInputs read_plan(const std::filesystem::path& path);

  // The SHA-256 a stored study's rows carry: of the plan's inputs and the
  // study's values, its findings and staircases in a canonical order.
  static std::string digest(const std::string& plan_sha256, const StudyOutcome& outcome);

 private:
  struct Shape;
  struct Loading;  // load()'s steps, table by table (power_store.cc)
  db::Database db_;
  std::string path_;
  std::string plan_sha256_;
  PlanInputs inputs_;
  std::unique_ptr<Shape> shape_;
};

}  // namespace hapticlab::planning
