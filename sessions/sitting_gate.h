#pragma once
// The gate before a session of a between-group design (protocols/sittings.h):
// a session is one sitting, so it runs only the participant's next
// sitting's trials, and it is refused before that sitting is due unless
// the operator overrides, which the session then logs in operator_action
// (type "override_due_date"). A protocol without groups passes as before.

#include <filesystem>
#include <optional>
#include <string>

namespace hapticlab::sessions {

struct SittingGate {
  // The sitting (= trial block) the session may run; nullopt: no groups,
  // the whole remaining schedule as before.
  std::optional<int> block;
  // Set when the operator overrode the due date: what to log.
  std::optional<std::string> override_detail;
};

// Reads the study (without recovery, like StudySession) and decides.
// Throws protocols::SittingTooEarly (the participant, the sitting, the due
// date, the override flag) when the next sitting is not due at now_unix_s
// and !override_due. A participant who has done every sitting gets a
// block no trial has: the session runs nothing, as with any finished
// schedule (the demo resumes a finished study so).
SittingGate check_sitting_gate(const std::filesystem::path& db_path, const std::string& participant,
                               double now_unix_s, bool override_due);

}  // namespace hapticlab::sessions
