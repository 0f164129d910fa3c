#pragma once
// The Wilson score interval for a binomial proportion (Wilson 1927;
// Agresti & Coull 1998 recommend it over the Wald interval, which fails
// near 0 and 1 — exactly where power and false-positive rates live).
#include <cstddef>

namespace hapticlab::analysis {

struct ProportionInterval {
  double low = 0.0;
  double high = 1.0;
};

// successes of trials, at confidence `level` in (0, 1) (default 95 %).
// Throws DataError for trials == 0, successes > trials or a bad level.
ProportionInterval wilson_interval(std::size_t successes, std::size_t trials, double level = 0.95);

}  // namespace hapticlab::analysis
