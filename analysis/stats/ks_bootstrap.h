#pragma once
// The thesis' Kolmogorov–Smirnov + moving block bootstrap comparison of a
// setting of interest with the control (High Fidelity) setting, Appendix I:
//
//   repeat m times:
//     pick a participant at random (among those with >= 2 control
//       repetitions and >= 1 repetition of the setting of interest);
//     pick a control repetition HF1, a second, different control repetition
//       HF2, and a repetition SI1 of the setting of interest;
//     resample each with the moving block bootstrap;
//     D_intra = D(HF1*, HF2*),  D_inter = D(HF1*, SI1*).
//   The 95 % ranges of D_intra and D_inter are their 2.5th and 97.5th
//   percentiles; the null hypothesis (no difference) is rejected when the two
//   ranges do not overlap.
//
// The thesis found this rule very conservative with 2–3 participants (3.3.7.2
// and the Appendix I discussion): it is here to reproduce that analysis, not
// as the primary test.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "analysis/stats/percentile.h"

namespace hapticlab::analysis {

// One participant's repetitions, each a time series in sample order.
struct ParticipantRepetitions {
  std::string participant;
  std::vector<std::vector<double>> control;  // e.g. High Fidelity repetitions
  std::vector<std::vector<double>> other;    // the setting of interest
};

// The fewest resamples whose 95 % range is not simply the smallest and the
// largest D: with m < 40 the 2.5 % and 97.5 % percentiles are the extremes
// (with m = 1 a single resample "showed" a significant difference). 100
// puts 2.5 resamples in each tail.
inline constexpr std::size_t kMinKsResamples = 100;

struct KsBootstrapOptions {
  std::size_t resamples = 1000;  // m; the thesis used 1000 (>= kMinKsResamples required)
  std::size_t block_length = 0;  // L in samples; required, >= 1 and <= every series length
  std::uint64_t seed = 1;        // same seed and data give the same result
  double coverage = 0.95;        // central range of each D population, in (0, 1)
  PercentileMethod percentile_method = PercentileMethod::kMatlab;
};

struct DRange {
  double low = 0.0;
  double high = 0.0;
};

struct KsBootstrapResult {
  DRange intra;  // range of D(HF1*, HF2*)
  DRange inter;  // range of D(HF1*, SI1*)
  bool significant = false;  // the two ranges do not overlap
  std::size_t participants_used = 0;
  std::vector<double> d_intra;  // every resample, in draw order
  std::vector<double> d_inter;
};

// True when [a.low, a.high] and [b.low, b.high] share no point.
bool ranges_disjoint(const DRange& a, const DRange& b);

// Throws DataError when no participant qualifies, when a series is shorter
// than the block length (naming participant and repetition), or for invalid
// options.
KsBootstrapResult ks_block_bootstrap(const std::vector<ParticipantRepetitions>& data,
                                     const KsBootstrapOptions& options);

}  // namespace hapticlab::analysis
