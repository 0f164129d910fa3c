#pragma once
// The shipped fit's point estimate (examples/population/fitted.json,
// "population"), written out for tests of core/, which do not read files of
// the planning layer: the free parameters rounded to 4 significant digits,
// the rest the defaults. FittedPointTest.TheCoreTestsFittedPointIsTheShippedFits
// fails when a re-fit leaves these behind.
#include "core/sim/population.h"

namespace hapticlab::testing {

inline PopulationParams shipped_fitted_point() {
  PopulationParams p;
  p.visual_gain_mean = 0.4678;
  p.consistency_median = 0.2982;
  p.force_level_log_sd = 0.5325;
  p.novice_force_factor = 1.216;
  return p;
}

}  // namespace hapticlab::testing
