#include "analysis/stats/wilson.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <boost/math/distributions/normal.hpp>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {

ProportionInterval wilson_interval(std::size_t successes, std::size_t trials, double level) {
  if (trials == 0) throw DataError("Wilson interval: no trials");
  if (successes > trials) {
    throw DataError("Wilson interval: " + std::to_string(successes) + " successes of " + std::to_string(trials) +
                    " trials");
  }
  if (!(level > 0.0 && level < 1.0)) throw DataError("Wilson interval: level must be in (0, 1)");
  const double z = boost::math::quantile(boost::math::normal(), 0.5 + level / 2.0);
  const double n = static_cast<double>(trials);
  const double p = static_cast<double>(successes) / n;
  const double z2 = z * z;
  const double centre = (p + z2 / (2.0 * n)) / (1.0 + z2 / n);
  const double half = z / (1.0 + z2 / n) * std::sqrt(p * (1.0 - p) / n + z2 / (4.0 * n * n));
  return {std::max(0.0, centre - half), std::min(1.0, centre + half)};
}

}  // namespace hapticlab::analysis
