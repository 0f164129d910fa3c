// Checks that folders are the shards of one plan and merges them into one
// plan folder (plan_merge.h).
#include "planning/plan_merge.h"

#include <algorithm>
#include <exception>
#include <map>
#include <set>
#include <stdexcept>
#include <utility>

#include "analysis/report/gnuplot.h"
#include "planning/plan_folder.h"
#include "planning/plan_lock.h"
#include "planning/power_store.h"
#include "protocols/protocol_json.h"

namespace hapticlab::planning {
namespace {

namespace fs = std::filesystem;

struct ShardFolders {
  std::vector<PlanInputs> plans;  // as each folder's plan_power.db stores it
  std::vector<fs::path> dirs;     // canonical, in the request's order
};

std::string shard_label(const PlanInputs& p) {
  return std::to_string(p.shard) + "/" + std::to_string(p.shards);
}

std::string joined(const std::vector<std::string>& items) {
  std::string list;
  for (const std::string& x : items) list += (list.empty() ? "" : "; ") + x;
  return list;
}

// Each folder named once, holding a shard's plan_power.db. An output
// folder that is one of the inputs would put the merged plan into a
// shard's store (refused there as another plan, but say why here).
ShardFolders read_shard_folders(const PlanMergeRequest& o) {
  const fs::path out = fs::weakly_canonical(fs::absolute(o.out));
  ShardFolders f;
  for (const std::string& d : o.shards) {
    const fs::path dir = fs::weakly_canonical(fs::absolute(d));
    if (dir == out) throw std::runtime_error("--out '" + o.out + "' is one of the shard folders it merges (" + d +
                                             "): name a folder of its own");
    if (std::find(f.dirs.begin(), f.dirs.end(), dir) != f.dirs.end())
      throw std::runtime_error("shard folder '" + d + "' is named twice");
    const fs::path db = dir / "plan_power.db";
    if (!fs::exists(db))
      throw std::runtime_error(d + ": no plan_power.db: not a folder of `plan power --shard` (or its run never began)");
    PlanInputs p = PowerStore::read_plan(db);
    if (p.shards < 2)
      throw std::runtime_error(d + ": holds a whole plan (" + p.describe() + "), not a shard of one; plan merge "
                               "joins the folders of `plan power --shard I/N`");
    f.dirs.push_back(dir);
    f.plans.push_back(std::move(p));
  }
  return f;
}

// One plan: every input the same but the shard, and each shard once.
void check_one_plan(const PlanMergeRequest& o, const std::vector<PlanInputs>& plans) {
  const PlanInputs& first = plans.front();
  std::vector<int> holder(static_cast<std::size_t>(first.shards), -1);
  for (std::size_t k = 0; k < plans.size(); ++k) {
    const PlanInputs& p = plans[k];
    std::vector<std::string> differ = plan_differences(first.whole(), p.whole());
    if (p.shards != first.shards)
      differ.push_back("the number of shards (" + std::to_string(first.shards) + " in " + o.shards.front() + ", " +
                       std::to_string(p.shards) + " here)");
    if (!differ.empty())
      throw std::runtime_error(o.shards[k] + ": a shard of another plan than " + o.shards.front() + " (" +
                               first.describe() + "): " + joined(differ) + " differ (\"then\" is " + o.shards.front() +
                               ", \"now\" " + o.shards[k] + "); plan merge joins the shards of one plan");
    int& h = holder[static_cast<std::size_t>(p.shard)];
    if (h >= 0)
      throw std::runtime_error("shard " + shard_label(p) + " is in both " + o.shards[static_cast<std::size_t>(h)] +
                               " and " + o.shards[k] + "; name each shard's folder once");
    h = static_cast<int>(k);
  }
  std::string missing;
  for (std::size_t i = 0; i < holder.size(); ++i)
    if (holder[i] < 0) missing += (missing.empty() ? "" : ", ") + std::to_string(i) + "/" + std::to_string(first.shards);
  if (!missing.empty())
    throw std::runtime_error("the plan has " + std::to_string(first.shards) + " shards, and " + missing +
                             (missing.find(',') == std::string::npos ? " is" : " are") +
                             " not among the folders given; run (or name) the missing shard's folder");
}

SimulatedStudyOptions plan_simulation(const PlanInputs& p) {
  SimulatedStudyOptions sim;
  sim.rate_Hz = p.rate_Hz;
  sim.max_trial_s = p.max_trial_s;
  return sim;
}

// The protocol the shards were made from, proven the same file and
// settings; fills the merge's protocol and whole plan.
void load_shards_protocol(const PlanMergeRequest& o, const PlanInputs& first, PlanMerge& m, std::string& path) {
  path = o.protocol.empty() ? first.protocol_file : o.protocol;
  if (!fs::exists(path))
    throw std::runtime_error("the shards were made from the protocol '" + first.protocol_file + "', which is not at " +
                             path + " from here: give its path with --protocol");
  m.protocol = protocols::load_protocol_file(path);
  const std::string protocol_text = protocols::read_protocol_text(path);
  m.whole = plan_inputs(m.protocol, first.protocol_file, protocol_text, first.seed, first.participants, first.studies,
                        plan_simulation(first));
  // The population is the shards' (merging simulates nothing).
  m.whole.population = first.population;
  m.whole.model_uncertainty = first.model_uncertainty;
  if (const std::vector<std::string> d = plan_differences(first.whole(), m.whole); !d.empty())
    throw std::runtime_error(path + ": not the protocol the shards were made from: " + joined(d) +
                             " (\"then\" is the shards', \"now\" this file's)");
}

// Every study of the merged store that is not there yet, added; throws
// saying how many are in it when one cannot be written.
void add_to_merged(PowerStore& merged, const std::map<std::pair<int, int>, StudyOutcome>& studies, PlanMerge& m) {
  const std::set<std::pair<int, int>> done = merged.done();  // merged before: the same studies, checked
  m.already = done.size();
  for (const auto& [key, s] : studies) {
    if (done.count(key)) continue;
    try {
      merged.add(s);
    } catch (const std::exception& e) {
      throw std::runtime_error(std::string(e.what()) + "; " + std::to_string(done.size() + m.added) + " of " +
                               std::to_string(studies.size()) + " studies are in " + m.store.string() +
                               ", the shards are untouched: free space, then run the same merge again");
    }
    ++m.added;
  }
}

}  // namespace

PlanMerge merge_plan_shards(const PlanMergeRequest& o, const std::function<void(const std::string&)>& note) {
  if (o.shards.empty()) throw std::runtime_error("plan merge: no shard folders given (name each shard's --out folder)");
  const ShardFolders shards = read_shard_folders(o);
  check_one_plan(o, shards.plans);
  PlanMerge m;
  std::string protocol_path;
  load_shards_protocol(o, shards.plans.front(), m, protocol_path);
  m.design = check_plan_design(m.protocol, protocol_path, m.whole.participants, m.whole.seed,
                               plan_simulation(shards.plans.front()));
  for (const std::string& n : m.design.notes) note(n);
  if (o.plots) (void)analysis::find_gnuplot();

  // Every shard's rows checked as its own run checks them, complete, while
  // no run of it can add to it.
  std::vector<PlanLock> locks;
  std::map<std::pair<int, int>, StudyOutcome> studies;
  for (std::size_t k = 0; k < shards.plans.size(); ++k) {
    locks.push_back(PlanLock::acquire(shards.dirs[k]));
    PowerStore shard(shards.dirs[k] / "plan_power.db", shards.plans[k], m.protocol);
    for (StudyOutcome& s : shard.load(/*complete=*/true)) studies[{s.participants, s.index}] = std::move(s);
  }

  prepare_plan_folder(o.out);
  const PlanLock lock = PlanLock::acquire(o.out);
  m.store = fs::path(o.out) / "plan_power.db";
  PowerStore merged(m.store, m.whole, m.protocol);
  m.studies = studies.size();
  add_to_merged(merged, studies, m);
  m.results = write_plan_results(m.protocol, m.whole, m.design, merged.load(/*complete=*/true), o.out, o.measure,
                                 o.plots);
  return m;
}

}  // namespace hapticlab::planning
