#include "analysis/transfer/transfer_ratio.h"

#include <cmath>
#include <sstream>
#include <string>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis::transfer {
namespace {

double mean_of(const std::vector<double>& v, const char* what) {
  if (v.empty()) throw DataError(std::string("transfer effectiveness ratio: ") + what + " has no participants (allowed: at least 1)");
  double s = 0.0;
  for (double x : v) {
    if (!std::isfinite(x) || x < 0.0) {
      std::ostringstream m;
      m << "transfer effectiveness ratio: " << what << " has value " << x << " (allowed: finite, >= 0)";
      throw DataError(m.str());
    }
    s += x;
  }
  return s / static_cast<double>(v.size());
}

}  // namespace

TransferRatio transfer_effectiveness_ratio(const std::vector<double>& control_y,
                                           const std::vector<double>& experimental_y,
                                           const std::vector<double>& experimental_x) {
  TransferRatio r;
  r.control_trials_to_criterion = mean_of(control_y, "the control group's trials to criterion");
  r.experimental_trials_to_criterion = mean_of(experimental_y, "the trained group's trials to criterion");
  r.training_trials = mean_of(experimental_x, "the trained group's training trials");
  if (!(r.training_trials > 0.0)) {
    throw DataError("transfer effectiveness ratio: the trained group has 0 training trials (allowed: > 0; "
                    "TER divides by the simulator practice)");
  }
  r.ter = (r.control_trials_to_criterion - r.experimental_trials_to_criterion) / r.training_trials;
  return r;
}

}  // namespace hapticlab::analysis::transfer
