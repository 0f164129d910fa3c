#include "sessions/sitting_gate.h"

#include <cmath>
#include <stdexcept>

#include "core/common/csv_format.h"

#include "db/study_db.h"
#include "protocols/sittings.h"
#include "sessions/study_progress.h"

namespace hapticlab::sessions {

SittingGate check_sitting_gate(const std::filesystem::path& db_path, const std::string& participant,
                               double now_unix_s, bool override_due) {
  SittingGate gate;
  if (!std::filesystem::exists(db_path)) return gate;  // StudySession names the missing file
  db::OpenOptions open;
  open.recover = false;  // recovery waits for the participant's lock (study_session.cc)
  db::StudyDb db(db_path, open);
  if (db.studies().empty()) return gate;
  const StudyProgress progress = study_progress(db);
  for (const ParticipantProgress& p : progress.participants) {
    if (p.code != participant || !p.sitting) continue;
    const SittingProgress& sp = *p.sitting;
    if (sp.next_phase == "done")
      throw std::runtime_error("participant " + participant + " has done all " + std::to_string(sp.sittings) +
                               " sittings of the protocol; nothing is left to run");
    gate.block = sp.sittings_done + 1;
    if (sp.due_unix_s && now_unix_s < *sp.due_unix_s) {
      if (!override_due) {
        const std::string sitting = sp.next_phase + " session " + std::to_string(sp.next_session);
        throw protocols::SittingTooEarly(
            "participant " + participant + "'s next sitting (" + sitting + ") is not due before " +
            protocols::utc_text(*sp.due_unix_s) + " (" + format_number(std::round((*sp.due_unix_s - now_unix_s) / 360.0) / 10.0) +
            " h from now): refused; the operator may override with " + protocols::kOverrideDueFlag + ", which is logged");
      }
      gate.override_detail = sp.next_phase + " session " + std::to_string(sp.next_session) + " due " +
                             protocols::utc_text(*sp.due_unix_s) + ", started " +
                             protocols::utc_text(now_unix_s) + " (operator override)";
    }
  }
  return gate;
}

}  // namespace hapticlab::sessions
