#pragma once
// Stage 1 of the study analysis: a trial's samples, chunk by chunk, decoded
// straight into the task-window accumulators (one pass, no whole-trial
// arrays), then summarized into its TrialRecord. Trials are independent, so
// read_trials spreads them over threads, each with its own read-only
// connection; the records come back in the order of the rows given, equal
// to the bit whatever the thread count.
#include <array>
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string_view>
#include <span>
#include <string>
#include <vector>

#include "analysis/metrics/device_energy.h"
#include "analysis/metrics/trial_metrics.h"
#include "analysis/stats/data_error.h"
#include "analysis/study/study_analysis.h"
#include "core/loop/task_event.h"
#include "db/study_db.h"

namespace hapticlab::analysis {

// One trial's measures from its task events and its samples, fed one
// sample at a time (each hand's in time order; the hands may interleave):
// what read_trial does with stored chunks, and what a simulated study
// (planning/) does with the loop's samples, without storing them.
class TrialAccumulator {
 public:
  // Starts a trial; buffers are kept from the previous one. Throws
  // DataError for a bad options.min_force_N.
  void start(std::span<const TaskEvent> events, const AnalysisOptions& options);
  // One sample of hand 0 (left) or 1 (right). A non-finite value does not
  // throw: the trial's measures become missing, saying why.
  void add(std::size_t hand, double t_s, const Vec3d& position_m, const Vec3d& velocity_m_per_s,
           const Vec3d& force_N) {
    ++samples_;
    if (t_s > trial_end_s_) trial_end_s_ = t_s;
    if (t_s < trial_start_s_) trial_start_s_ = t_s;
    if (!accumulate_) return;
    try {
      acc_[hand].add(t_s, position_m, velocity_m_per_s, force_N);
    } catch (const DataError& e) {
      fail(e.what());
    }
  }
  // The same sample's device values, for the energy measure
  // (device_energy.h): joints as read, commanded joint forces, VE force.
  void add_device(std::size_t hand, const std::array<double, 5>& raw_position,
                  const std::array<double, 3>& joint_force, const Vec3d& ve_force_N) {
    energy_[hand].add(raw_position, joint_force, ve_force_N);
    have_energy_ = true;
  }
  // Fills rec's window, measures, quantiles, KS series and problem (its
  // identity fields are the caller's). `damaged_chunks` (read_trial's) come
  // first among the reasons for missing measures.
  void finish(TrialRecord& rec, std::vector<std::string> damaged_chunks = {});

 private:
  void fail(const std::string& why);

  const AnalysisOptions* options_ = nullptr;
  std::vector<TaskEvent> events_;
  TaskWindowResult provisional_;
  std::array<WindowAccumulator, 2> acc_;
  std::array<WindowValues, 2> values_;
  std::array<EnergyAccumulator, 2> energy_;
  bool have_energy_ = false;
  bool accumulate_ = false;
  std::size_t samples_ = 0;
  double trial_end_s_ = 0.0;
  double trial_start_s_ = 0.0;
  std::string data_error_;
};

// The task event named `name` as the database stores it (to_string of
// TaskEventType), or nullopt for the runner's and writer's own events.
std::optional<TaskEventType> task_event_type(std::string_view name);

// One trial (its row from StudyDb::trials). A damaged chunk, a trial without
// samples or task window, or a non-finite value leaves the measures missing
// (NaN) and says why in `problem`; throws db::DbError only for the database.
TrialRecord read_trial(db::StudyDb& db, const db::TrialRow& row, const AnalysisOptions& options);

// read_trial for every row, on `threads` threads (0: one per core; at most
// one per row). Threads other than the caller's open `db_path` read-only
// without an integrity check (the caller opened it and checked it as it
// chose). A DbError in any thread is rethrown here, after all have stopped.
std::vector<TrialRecord> read_trials(db::StudyDb& db, const std::vector<db::TrialRow>& rows,
                                     const AnalysisOptions& options, std::size_t threads);

}  // namespace hapticlab::analysis
