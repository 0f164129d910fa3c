#pragma once
// The input of the learning and transfer analyses (issue 38 §2-3): one row
// per trial in long format,
//
//   participant,group,phase,trial,completion_time_s
//   P01,HiFi,pre,1,41.2
//
// phase is one of pre, training, post, retention; trial is the trial's
// 1-based index within the participant's phase; the measure column is named
// by the caller. Independent of how the study stored its groups and phases
// (the lead wires studies to it).
#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "analysis/io/long_csv.h"

namespace hapticlab::analysis::learning {

enum class Phase { kPre, kTraining, kPost, kRetention };
const char* phase_name(Phase phase);

struct TrialColumns {
  std::string participant = "participant";
  std::string group = "group";
  std::string phase = "phase";
  std::string trial = "trial";
  std::string measure = "completion_time_s";
};

struct PhaseTrials {
  std::vector<double> trial;  // ascending
  std::vector<double> value;
};

struct ParticipantTrials {
  std::string participant;
  std::string group;
  std::map<Phase, PhaseTrials> phases;  // only the phases with trials
};

struct TrialTable {
  std::string measure;
  std::vector<ParticipantTrials> participants;  // in order of first appearance
  std::vector<std::string> groups;              // sorted
};

// Throws DataError naming the file, line, column and value for a missing
// column, an empty or non-finite measure (NaN included), an unknown phase,
// a trial index that is not an integer >= 1 or repeats within a
// participant's phase, and a participant listed in two groups.
TrialTable read_trial_table(const LongCsv& csv, const TrialColumns& columns);

}  // namespace hapticlab::analysis::learning
