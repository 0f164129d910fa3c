#include "sessions/sitting_gate.h"

#include "db/study_db.h"
#include "protocols/group_assignment.h"
#include "protocols/protocol_json.h"
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
  for (std::size_t i = 0; i < progress.participants.size(); ++i) {
    const ParticipantProgress& p = progress.participants[i];
    if (p.code != participant || !p.sitting) continue;
    const SittingProgress& sp = *p.sitting;
    gate.block = sp.sittings_done + 1;
    // All done: a block no trial has, so the session runs nothing, as a
    // finished schedule of any protocol does.
    if (sp.next_phase == "done") return gate;
    const auto design = protocols::group_design_from_protocol_text(progress.study.protocol_json, db_path.string());
    const auto groups = protocols::assign_groups(*design, db_path.string());
    std::size_t index = 0;
    while (design->participants[index].code != participant) ++index;
    const auto sittings = protocols::group_sittings(*design, groups[index]);
    const protocols::SittingDue due{static_cast<std::size_t>(sp.sittings_done), sp.due_unix_s};
    if (protocols::check_sitting_start(participant, sittings, due, now_unix_s, override_due) ==
        protocols::SittingStart::kOverridden)
      gate.override_detail = sp.next_phase + " session " + std::to_string(sp.next_session) + " due " +
                             protocols::utc_text(*sp.due_unix_s) + ", started " + protocols::utc_text(now_unix_s) +
                             " (operator override)";
  }
  return gate;
}

}  // namespace hapticlab::sessions
