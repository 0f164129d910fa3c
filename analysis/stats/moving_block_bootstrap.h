#pragma once
// The moving block bootstrap (Künsch 1989; Lahiri 2003), which the thesis
// used because force and motion samples are temporally correlated
// (Appendix I): a series of n samples is cut into its n − L + 1 overlapping
// blocks of L consecutive samples; ceil(n/L) blocks are drawn uniformly with
// replacement, laid end to end and cut to n samples. L = 1 is the ordinary
// (independent) bootstrap; L should cover the correlation length.
#include <cstddef>
#include <span>
#include <vector>

#include "analysis/stats/split_mix64.h"

namespace hapticlab::analysis {

// series non-empty; block_length in [1, series.size()]; throws DataError
// otherwise. `out` is resized to series.size(). Draws ceil(n/L) block starts
// from rng, in order, with rng.below(n − L + 1).
void moving_block_resample(std::span<const double> series, std::size_t block_length,
                           SplitMix64& rng, std::vector<double>& out);

}  // namespace hapticlab::analysis
