#include "sessions/study_setup.h"

#include <map>
#include <stdexcept>
#include <vector>

#include "protocols/protocol_json.h"
#include "protocols/schedule.h"

namespace hapticlab::sessions {

CreatedStudy create_study(db::StudyDb& db, const std::filesystem::path& protocol_file,
                          const std::string& software_version) {
  if (!db.studies().empty())
    throw std::runtime_error(db.path() + ": already holds a study; create each study in a new database file");
  // Read once: the text stored is the text parsed, and a huge or endless
  // file (/dev/zero) stops at the size cap.
  const std::string text = protocols::read_protocol_text(protocol_file);
  const protocols::Protocol protocol =
      protocols::protocol_from_json_text(text, protocol_file.parent_path(), protocol_file.string());
  const protocols::StudyPlan plan = protocols::make_study_plan(protocol);

  db::Transaction tx(db.connection());
  CreatedStudy created;
  created.external_ve = protocol.ve == protocols::Ve::kExternal;
  created.study_id = db.add_study({protocol.study, text, protocol.seed, software_version});
  std::map<std::size_t, std::int64_t> setting_ids;  // protocol index -> row
  for (std::size_t i = 0; i < protocol.settings.size(); ++i)
    setting_ids[i] = db.add_setting(created.study_id, protocol.settings[i].settings);
  // A staircase's strengths are made during the sessions, from these.
  if (protocol.staircase) {
    NamedSettings base = protocol.staircase->base.settings;
    base.name = protocols::staircase_base_row_name(base.name);
    db.add_setting(created.study_id, base);
  }
  for (const protocols::ParticipantPlan& p : plan.participants) {
    const std::int64_t participant_id = db.add_participant(created.study_id, p.code);
    ++created.participants;
    for (const protocols::PlannedTrial& t : p.trials) {
      db.add_trial({participant_id, std::string(protocols::task_name(t.task)), setting_ids.at(t.setting_index),
                    t.repetition, t.block, t.position});
      ++created.trials;
    }
  }
  tx.commit();
  if (!protocol.staircase) {
    std::vector<bool> scheduled(protocol.settings.size(), false);
    for (const protocols::ParticipantPlan& p : plan.participants)
      for (const protocols::PlannedTrial& t : p.trials) scheduled[t.setting_index] = true;
    for (std::size_t i = 0; i < protocol.settings.size(); ++i)
      if (!scheduled[i]) created.unscheduled_settings.push_back(protocol.settings[i].settings.name);
  }
  return created;
}

}  // namespace hapticlab::sessions
