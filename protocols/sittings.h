#pragma once
// A participant's sittings in a between-group design (transfer_design.h)
// and when the next one is due.
//
// A sitting is one session at the lab: a test, or one training session.
// Its trials are the phase's trials per task, at the phase's setting (the
// tests) or the participant's group's training setting (training; a
// control group without one skips training). Sitting k > 0 is due
// min_gap_h hours of its phase after the end of sitting k - 1; before
// that it is refused (SittingTooEarly, naming the due date) unless the
// operator overrides, which the caller must log.
//
// Time is an argument (now_unix_s), never read from a clock here, so tests
// can move days forward.

#include <cstddef>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "protocols/protocol.h"

namespace hapticlab::protocols {

struct Sitting {
  PhaseKind phase = PhaseKind::kPreTest;
  int session = 1;           // 1-based within its phase
  std::string setting;       // the setting's name
  std::map<std::string, int> trials;  // by task name
  double min_gap_h = 0.0;    // least time after the previous sitting's end
};

// The sittings of group `group` (index into TransferDesign::groups), in order.
std::vector<Sitting> group_sittings(const Protocol& protocol, std::size_t group);

// Where a participant stands: `done` sittings finished (the last ended at
// last_end_unix_s). next == sittings.size() when all are done; due_unix_s
// is nullopt for the first sitting (due at once) and when all are done.
struct SittingDue {
  std::size_t next = 0;
  std::optional<double> due_unix_s;
};
SittingDue next_sitting_due(const std::vector<Sitting>& sittings, std::size_t done,
                            std::optional<double> last_end_unix_s);

// "2026-11-28T09:15:00Z" (UTC, to the second).
std::string utc_text(double unix_s);

// A sitting started before its due date without the operator's override.
class SittingTooEarly : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// What happened when the operator asked to start the next sitting.
enum class SittingStart { kDue, kOverridden };

// Refuses (SittingTooEarly: the participant, the sitting, its due date and
// how long until then, and the override flag's name) a sitting asked for
// before it is due, unless `override_early`; kOverridden then tells the
// caller to log the override. std::invalid_argument when all are done.
SittingStart check_sitting_start(const std::string& participant, const std::vector<Sitting>& sittings,
                                 const SittingDue& due, double now_unix_s, bool override_early);

// The command-line flag that overrides a due date.
inline constexpr const char* kOverrideDueFlag = "--override-due-date";

}  // namespace hapticlab::protocols
