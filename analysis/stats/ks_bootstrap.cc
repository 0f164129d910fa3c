#include "analysis/stats/ks_bootstrap.h"

#include <algorithm>
#include <cmath>

#include "analysis/stats/data_error.h"
#include "analysis/stats/kolmogorov_smirnov.h"
#include "analysis/stats/moving_block_bootstrap.h"
#include "analysis/stats/split_mix64.h"

namespace hapticlab::analysis {
namespace {

void check_lengths(const ParticipantRepetitions& p, const std::vector<std::vector<double>>& reps,
                   const char* which, std::size_t block_length) {
  for (std::size_t r = 0; r < reps.size(); ++r) {
    if (reps[r].size() < block_length) {
      throw DataError("ks_block_bootstrap(): participant '" + p.participant + "', " + which +
                      " repetition " + std::to_string(r + 1) + " has " +
                      std::to_string(reps[r].size()) + " samples, fewer than the block length " +
                      std::to_string(block_length));
    }
    for (double v : reps[r]) {
      if (!std::isfinite(v)) {
        throw DataError("ks_block_bootstrap(): participant '" + p.participant + "', " + which +
                        " repetition " + std::to_string(r + 1) + " holds a non-finite value");
      }
    }
  }
}

DRange central_range(std::vector<double> values, double coverage, PercentileMethod method) {
  std::sort(values.begin(), values.end());
  const double tail_percent = 50.0 * (1.0 - coverage);
  return {percentile_sorted(values, tail_percent, method),
          percentile_sorted(values, 100.0 - tail_percent, method)};
}

}  // namespace

bool ranges_disjoint(const DRange& a, const DRange& b) { return a.high < b.low || b.high < a.low; }

KsBootstrapResult ks_block_bootstrap(const std::vector<ParticipantRepetitions>& data,
                                     const KsBootstrapOptions& options) {
  if (options.resamples < 1) throw DataError("ks_block_bootstrap(): resamples must be >= 1");
  if (options.block_length < 1) {
    throw DataError("ks_block_bootstrap(): block length must be >= 1 sample (choose it to "
                    "cover the autocorrelation of the data)");
  }
  if (!(options.coverage > 0.0 && options.coverage < 1.0)) {
    throw DataError("ks_block_bootstrap(): coverage is " + std::to_string(options.coverage) +
                    ", but must be > 0 and < 1");
  }
  // Participants who can supply HF1 != HF2 and SI1.
  std::vector<const ParticipantRepetitions*> eligible;
  for (const auto& p : data) {
    if (p.control.size() < 2 || p.other.empty()) continue;
    check_lengths(p, p.control, "control", options.block_length);
    check_lengths(p, p.other, "other", options.block_length);
    eligible.push_back(&p);
  }
  if (eligible.empty()) {
    throw DataError("ks_block_bootstrap(): no participant has at least 2 control repetitions "
                    "and 1 repetition of the other setting");
  }

  KsBootstrapResult result;
  result.participants_used = eligible.size();
  result.d_intra.reserve(options.resamples);
  result.d_inter.reserve(options.resamples);
  SplitMix64 rng(options.seed);
  std::vector<double> hf1;
  std::vector<double> hf2;
  std::vector<double> si1;
  for (std::size_t m = 0; m < options.resamples; ++m) {
    // Resample at every level: participant, repetitions, then samples.
    const auto& p = *eligible[rng.below(eligible.size())];
    const auto first = static_cast<std::size_t>(rng.below(p.control.size()));
    auto second = static_cast<std::size_t>(rng.below(p.control.size() - 1));
    if (second >= first) ++second;  // a different repetition, uniformly
    const auto other = static_cast<std::size_t>(rng.below(p.other.size()));
    moving_block_resample(p.control[first], options.block_length, rng, hf1);
    moving_block_resample(p.control[second], options.block_length, rng, hf2);
    moving_block_resample(p.other[other], options.block_length, rng, si1);
    std::sort(hf1.begin(), hf1.end());
    std::sort(hf2.begin(), hf2.end());
    std::sort(si1.begin(), si1.end());
    result.d_intra.push_back(ks_statistic_sorted(hf1, hf2));
    result.d_inter.push_back(ks_statistic_sorted(hf1, si1));
  }
  result.intra = central_range(result.d_intra, options.coverage, options.percentile_method);
  result.inter = central_range(result.d_inter, options.coverage, options.percentile_method);
  result.significant = ranges_disjoint(result.intra, result.inter);
  return result;
}

}  // namespace hapticlab::analysis
