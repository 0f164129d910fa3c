#pragma once
// A between-group training study's analysis (issue 38 §2-3), from a
// study's analysed trials: per task, each trial's completion time placed by
// its participant's group and its sitting's phase (protocols/sittings.h:
// a group design stores the sitting as the trial's block), then the
// transfer analysis (groups compared on the post-test and retention
// change from the pre-test, analysis/transfer/) and each participant's
// learning curve over the training phase (analysis/learning/).
//
// The within-participant tables (Friedman, pairwise against a control) do
// not apply to such a study: the settings differ between groups and phases,
// not within a participant's sitting. analyze and the demo write this
// instead of them.
#include <filesystem>
#include <string>
#include <vector>

#include "analysis/learning/learning_analysis.h"
#include "analysis/learning/trial_table.h"
#include "analysis/study/study_analysis.h"
#include "analysis/transfer/transfer_analysis.h"

namespace hapticlab::analysis {

struct TaskGroupAnalysis {
  std::string task;
  learning::TrialTable table;           // completion_time_s by participant, group, phase, trial
  std::optional<transfer::TransferAnalysis> transfer;
  std::string transfer_refusal;         // why there is no transfer analysis (named)
  learning::LearningAnalysis learning;  // the training phase's curves
  std::string learning_refusal;         // why there are none (named)
};

// Empty when the study has no group design. Complete trials with a task
// window only (as the measures are). Throws DataError for a trial whose
// block is not one of its participant's sittings.
std::vector<TaskGroupAnalysis> analyze_group_design(const StudyAnalysis& analysis);

struct GroupDesignFiles {
  std::filesystem::path markdown;              // OUT/transfer.md
  std::vector<std::filesystem::path> written;  // every file, the markdown's first
};

// Writes OUT/transfer.md (every task's transfer analysis and curve table),
// OUT/learning_TASK_curves.csv, OUT/learning_TASK_trials.csv and, with
// `gnuplot` not empty, the learning figures in OUT/figures/learning_TASK/.
GroupDesignFiles write_group_design(const std::vector<TaskGroupAnalysis>& tasks, const std::filesystem::path& out,
                                    const std::filesystem::path& gnuplot);

}  // namespace hapticlab::analysis
