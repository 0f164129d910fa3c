#pragma once
// The samples of a Kolmogorov–Smirnov comparison of two treatments,
// gathered from long-format observations: each treatment's values pooled
// (the KS test, kolmogorov_smirnov.h) and each participant's repetitions as
// time series (the moving block bootstrap, ks_bootstrap.h).
#include <cstddef>
#include <string>
#include <vector>

#include "analysis/stats/block_table.h"
#include "analysis/stats/ks_bootstrap.h"

namespace hapticlab::analysis {

struct KsSamples {
  std::vector<double> control;  // every value of the control treatment, in row order
  std::vector<double> other;    // every value of the other treatment, in row order
  // One entry per block (participant) with a row of either treatment, in
  // order of first appearance; each repetition (block, treatment,
  // replicate) a series of its values in row order, repetitions in order
  // of first appearance.
  std::vector<ParticipantRepetitions> participants;
};

// The rows `rows` of `observations` (e.g. one group's) whose treatment is
// `control` or `other`. Throws DataError "<source>: no rows with
// <treatment_column> = '<name>'" when either treatment has no row.
KsSamples gather_ks_samples(const std::vector<Observation>& observations, const std::vector<std::size_t>& rows,
                            const std::string& control, const std::string& other, const std::string& source,
                            const std::string& treatment_column);

}  // namespace hapticlab::analysis
