#include "analysis/stats/ks_bootstrap.h"

#include <algorithm>
#include <cmath>

#include "analysis/stats/data_error.h"
#include "analysis/stats/ks_rank_walk.h"
#include "analysis/stats/moving_block_bootstrap.h"
#include "analysis/stats/split_mix64.h"

namespace hapticlab::analysis {
namespace {

void check_lengths(const ParticipantRepetitions& p, const std::vector<std::vector<double>>& reps,
                   const char* which, std::size_t block_length) {
  for (std::size_t r = 0; r < reps.size(); ++r) {
    if (reps[r].size() < block_length) {
      throw DataError("KS bootstrap: participant '" + p.participant + "', " + which +
                      " repetition " + std::to_string(r + 1) + " has " +
                      std::to_string(reps[r].size()) + " samples, fewer than the block length " +
                      std::to_string(block_length));
    }
    for (double v : reps[r]) {
      if (!std::isfinite(v)) {
        throw DataError("KS bootstrap: participant '" + p.participant + "', " + which +
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

// The participants who can supply HF1 != HF2 and SI1, after checking the
// options and those participants' series.
std::vector<const ParticipantRepetitions*> eligible_participants(
    const std::vector<ParticipantRepetitions>& data, const KsBootstrapOptions& options) {
  if (options.resamples < kMinKsResamples)
    throw DataError("KS bootstrap: resamples is " + std::to_string(options.resamples) + ", but must be >= " +
                    std::to_string(kMinKsResamples) + ": fewer give a 95 % range that is only the extremes of the "
                    "resamples (the thesis used 1000)");
  if (options.block_length < 1) {
    throw DataError("KS bootstrap: block length must be >= 1 sample (choose it to "
                    "cover the autocorrelation of the data)");
  }
  if (!(options.coverage > 0.0 && options.coverage < 1.0)) {
    throw DataError("KS bootstrap: coverage is " + std::to_string(options.coverage) +
                    ", but must be > 0 and < 1");
  }
  std::vector<const ParticipantRepetitions*> eligible;
  for (const auto& p : data) {
    if (p.control.size() < 2 || p.other.empty()) continue;
    check_lengths(p, p.control, "control", options.block_length);
    check_lengths(p, p.other, "other", options.block_length);
    eligible.push_back(&p);
  }
  if (eligible.empty()) {
    throw DataError("KS bootstrap: no participant has at least 2 control repetitions "
                    "and 1 repetition of the other setting");
  }
  return eligible;
}

// D depends only on the order of the values, so each participant's series
// are replaced by their ranks among all of that participant's values. A
// resample is then counted into a histogram over those ranks instead of
// being sorted: O(n + U) rather than O(n log n) per series, and the same D,
// bit for bit (the walk in ks_block_bootstrap evaluates |i/n1 − j/n2| at the
// same points).
struct RankedParticipant {
  std::vector<std::vector<double>> control;  // ranks, as exact doubles
  std::vector<std::vector<double>> other;
  std::size_t levels = 0;                    // distinct values U
};

RankedParticipant ranked_participant(const ParticipantRepetitions& p) {
  std::vector<double> levels;
  for (const auto* reps : {&p.control, &p.other})
    for (const auto& series : *reps) levels.insert(levels.end(), series.begin(), series.end());
  std::sort(levels.begin(), levels.end());
  levels.erase(std::unique(levels.begin(), levels.end()), levels.end());
  auto to_ranks = [&](const std::vector<std::vector<double>>& reps) {
    std::vector<std::vector<double>> out;
    for (const auto& series : reps) {
      auto& r = out.emplace_back();
      r.reserve(series.size());
      for (double v : series) {
        r.push_back(static_cast<double>(std::lower_bound(levels.begin(), levels.end(), v) - levels.begin()));
      }
    }
    return out;
  };
  RankedParticipant ranked;
  ranked.control = to_ranks(p.control);
  ranked.other = to_ranks(p.other);
  ranked.levels = levels.size();
  return ranked;
}

}  // namespace

bool ranges_disjoint(const DRange& a, const DRange& b) { return a.high < b.low || b.high < a.low; }

KsBootstrapResult ks_block_bootstrap(const std::vector<ParticipantRepetitions>& data,
                                     const KsBootstrapOptions& options) {
  const std::vector<const ParticipantRepetitions*> eligible = eligible_participants(data, options);
  std::vector<RankedParticipant> ranked;
  ranked.reserve(eligible.size());
  std::size_t max_levels = 0;
  for (const ParticipantRepetitions* p : eligible) {
    ranked.push_back(ranked_participant(*p));
    max_levels = std::max(max_levels, ranked.back().levels);
  }

  KsBootstrapResult result;
  result.participants_used = eligible.size();
  result.d_intra.reserve(options.resamples);
  result.d_inter.reserve(options.resamples);
  SplitMix64 rng(options.seed);
  std::vector<double> hf1;
  std::vector<double> hf2;
  std::vector<double> si1;
  std::vector<std::uint32_t> count1(max_levels, 0);
  std::vector<std::uint32_t> count2(max_levels, 0);
  std::vector<std::uint32_t> count3(max_levels, 0);
  std::vector<std::uint64_t> touched((max_levels + 63) / 64, 0);
  for (std::size_t m = 0; m < options.resamples; ++m) {
    // Resample at every level: participant, repetitions, then samples.
    const RankedParticipant& p = ranked[rng.below(eligible.size())];
    const auto first = static_cast<std::size_t>(rng.below(p.control.size()));
    auto second = static_cast<std::size_t>(rng.below(p.control.size() - 1));
    if (second >= first) ++second;  // a different repetition, uniformly
    const auto other = static_cast<std::size_t>(rng.below(p.other.size()));
    moving_block_resample(p.control[first], options.block_length, rng, hf1);
    moving_block_resample(p.control[second], options.block_length, rng, hf2);
    moving_block_resample(p.other[other], options.block_length, rng, si1);
    const auto count = [&touched](const std::vector<double>& ranks, std::vector<std::uint32_t>& histogram) {
      for (double r : ranks) {
        const auto u = static_cast<std::size_t>(r);
        ++histogram[u];
        touched[u / 64] |= std::uint64_t{1} << (u % 64);
      }
    };
    count(hf1, count1);
    count(hf2, count2);
    count(si1, count3);
    const KsPairD d =
        ks_rank_walk(count1, count2, count3, touched, p.levels, hf1.size(), hf2.size(), si1.size());
    result.d_intra.push_back(d.d12);
    result.d_inter.push_back(d.d13);
  }
  result.intra = central_range(result.d_intra, options.coverage, options.percentile_method);
  result.inter = central_range(result.d_inter, options.coverage, options.percentile_method);
  result.significant = ranges_disjoint(result.intra, result.inter);
  return result;
}

}  // namespace hapticlab::analysis
