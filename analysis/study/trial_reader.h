#pragma once
// Stage 1 of the study analysis: a trial's samples, chunk by chunk, decoded
// straight into the task-window accumulators (one pass, no whole-trial
// arrays), then summarized into its TrialRecord. Trials are independent, so
// read_trials spreads them over threads, each with its own read-only
// connection; the records come back in the order of the rows given, equal
// to the bit whatever the thread count.
#include <cstddef>
#include <filesystem>
#include <vector>

#include "analysis/study/study_analysis.h"
#include "db/study_db.h"

namespace hapticlab::analysis {

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
