#pragma once
// What a transfer design can detect (issue 38 §4): for each group size,
// `studies` simulated transfer studies (transfer_study.h) with fresh seeds;
// in each, every other group is compared with the reference group (the
// design's first) on the post-test and on the retention test, each as the
// change from the participant's own pre-test (or, in a design without a
// pre-test, as the test's time itself); the share of studies in which a
// comparison is significant is its power, with a Wilson 95 % interval.
//
// The test is passed in (`GroupTest`), so planning does not choose the
// analysis: `hapticlab plan power` passes the transfer analysis' exact
// permutation test (analysis/transfer/, docs/analysis.md).
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "planning/transfer_study.h"

namespace hapticlab::planning {

// The p value of a comparison of group `a`'s values with group `b`'s
// (each participant's post- or retention-minus-pre time [s], or the
// test's time without a pre-test); NaN when it
// cannot be computed (too few values).
using GroupTest = std::function<double(const std::vector<double>& a, const std::vector<double>& b)>;

struct TransferPowerOptions {
  std::vector<int> per_group{8};  // group sizes, each 1..999
  int studies = 100;              // per group size, >= 1
  std::uint64_t seed = 1;
  double alpha = 0.05;            // in (0, 1)
  int jobs = 1;                   // studies simulated at once, >= 1
  TransferOptions simulation;
};

struct TransferPowerRow {
  int per_group = 0;
  std::string test;       // "post" or "retention"
  std::string group;      // the trained group compared...
  std::string reference;  // ...with this one (the design's first)
  int studies = 0;        // studies in which the test could be computed
  int significant = 0;
  double power = 0.0;     // significant / studies
  double power_low = 0.0, power_high = 0.0;  // Wilson 95 %
  // The median over studies of the difference of the groups' median
  // changes (group minus reference) [s]: negative means the group improved
  // more (its times fell further).
  double median_effect_s = 0.0;
};

struct TransferPower {
  std::vector<TransferPowerRow> rows;  // by group size, then test, then group
  int trials_run = 0;
  int trials_timed_out = 0;
  std::uint64_t updates = 0;
};

// The seed of study `index` with `per_group` participants per group: a
// pure function, so a re-run simulates the same studies.
std::uint64_t transfer_study_seed(std::uint64_t seed, int per_group, int index) noexcept;

// Throws std::invalid_argument (design, options).
TransferPower transfer_power(const TransferDesign& design, const TransferPowerOptions& options,
                             const GroupTest& test);

}  // namespace hapticlab::planning
