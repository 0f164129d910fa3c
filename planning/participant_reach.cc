// The participant-level power that is 0 by construction, said so
// (participant_reach.h). The numbers come from the test's own functions,
// so the note follows any change of the test or the level.
#include "planning/participant_reach.h"

#include <cstdio>

#include "analysis/stats/pairwise_friedman.h"
#include "analysis/stats/sign_flip.h"
#include "analysis/study/headline_format.h"

namespace hapticlab::planning {

std::string participant_power_note(int participants, double alpha, std::size_t comparisons) {
  const double level = comparisons > 0 ? analysis::sidak_level(alpha, comparisons) : alpha;
  const std::size_t n = participants > 0 ? static_cast<std::size_t>(participants) : 0;
  const double smallest = analysis::sign_flip_smallest_p(n);
  if (smallest < level) return {};
  char p[32];
  std::snprintf(p, sizeof p, "%.2g", smallest);
  const std::string count = std::to_string(participants);
  // Beyond 24 differences the test is Monte Carlo and its floor is no longer 2/2^n.
  const std::string formula = n <= 24 ? "2/2^" + count + " = " : std::string();
  const std::size_t needed = analysis::sign_flip_differences_needed(level);
  char alpha_text[32];
  std::snprintf(alpha_text, sizeof alpha_text, "%g", alpha);
  return "participant-level power is 0 by construction with " + count + " participant" +
         (participants == 1 ? "" : "s") + ": the sign-flip test's smallest p, " + formula + p +
         ", is not below the Šidák level " + analysis::format_level(level) + " (alpha " + alpha_text + ", m = " +
         std::to_string(comparisons) + " comparison" + (comparisons == 1 ? "" : "s") + "); " +
         (needed == 0 ? std::string("no number of participants can reach it")
                      : "it needs at least " + std::to_string(needed) + " participants");
}

}  // namespace hapticlab::planning
