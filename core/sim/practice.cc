#include "core/sim/practice.h"

#include <stdexcept>
#include <string>

#include "core/common/csv_format.h"

namespace hapticlab {

void LearningModel::validate() const {
  if (!(force_free_share >= 0.0 && force_free_share <= 1.0))
    throw std::invalid_argument("learning.force_free_share is " + format_number(force_free_share) +
                                ", but must be within 0..1");
}

double effective_practice_trials(const PracticeSoFar& practice, const LearningModel& model) noexcept {
  // 1.0·n + 0.0·m == n exactly for a finite m: the fitted model unchanged.
  return model.force_free_share * static_cast<double>(practice.trials) +
         (1.0 - model.force_free_share) * practice.force_informed_trials;
}

}  // namespace hapticlab
