#pragma once
// The primary comparison of a between-group transfer design (issue 38 §3):
// each participant's score in a test phase is the median of its trials
// there; the outcome is the change from the pre-test (post - pre, and
// retention - pre), so each participant is its own baseline. Groups are
// compared on the change by the rank permutation test
// (group_permutation.h), and each group against a reference group by the
// Hodges-Lehmann shift with its exact interval (hodges_lehmann.h). With a
// declared control group (trained on no simulator) and a proficiency
// criterion, Roscoe's transfer effectiveness ratio (transfer_ratio.h).
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "analysis/learning/trial_table.h"
#include "analysis/transfer/group_permutation.h"
#include "analysis/transfer/hodges_lehmann.h"
#include "analysis/transfer/transfer_ratio.h"

namespace hapticlab::analysis::transfer {

struct TransferOptions {
  // The group trained on no simulator; also the reference of the shifts.
  std::optional<std::string> control_group;
  // The reference of the shifts when there is no control group (default:
  // the first group by name).
  std::optional<std::string> reference_group;
  // Proficiency criterion for the TER's trials to criterion.
  std::optional<double> criterion;
  bool higher_is_better = false;
  double level = 0.95;
  PermutationOptions permutation;
};

struct ParticipantChange {
  std::string participant, group;
  double pre = 0.0, post = 0.0;
  std::optional<double> retention;
};

struct ShiftVsReference {
  std::string group;  // shift = group - reference
  ShiftEstimate shift;
};

struct GroupComparison {
  std::string outcome;  // "post-pre" or "retention-pre"
  std::vector<std::string> groups;
  std::vector<std::size_t> sizes;
  std::vector<double> median_change;
  std::optional<PermutationResult> test;  // nullopt when refused
  std::string refusal;
  std::vector<ShiftVsReference> shifts;
  std::vector<std::string> excluded;  // participants without this phase
};

struct GroupTransfer {
  std::string group;
  std::optional<TransferRatio> ratio;
  std::string refusal;  // why there is no ratio
};

struct TransferAnalysis {
  std::string measure;
  std::string reference;
  std::vector<ParticipantChange> participants;
  std::vector<GroupComparison> comparisons;  // post-pre, then retention-pre if any
  std::vector<GroupTransfer> transfer;       // one per non-control group
  std::string transfer_refusal;              // when no TER at all (no control group ...)
};

// Throws DataError for a participant without a pre- or post-test trial, a
// declared control or reference group with no participants, fewer than two
// groups, or a control group that has training trials.
TransferAnalysis analyze_transfer(const learning::TrialTable& table, const TransferOptions& options);

// Human-readable summary (the command prints it).
void write_transfer_text(const TransferAnalysis& analysis, std::ostream& out);

}  // namespace hapticlab::analysis::transfer
